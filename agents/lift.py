"""The logistics role of a stage-2 model with a lift head (issue 42 item 6: the high level
decides logistics too).

One SB3 model (``agents.candidates.CandidateModelEvaluator`` over a MaskablePPO saved with
``lift_features``) makes both of the high level's decisions: which target a crew walks to, and
whether a crew fetching at a storage asks for the next crane lift now. The second is a
``cmdp_pymunk.logistics.Logistics`` role (``ModelLogistics``), asked by the engine at the
decision levels saved with the model (shares of a crane lift, ``logistics.Levels``): its
answer is the policy's argmax over the two lift answers, from one forward pass over the lift
question's observation (the lift features of ``logistics.Learned``'s names and the crew
type's one-hot; ``CandidateView.lift_question``). The engine knows nothing of SB3: it sees a
role.

``agents.candidates.logistics_of(evaluator)`` is how the commands find the role of an
evaluator that has one (``training.runs.runner.make_engine``: used where ``--logistics`` is
left at ``case``).
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING

from cmdp_pymunk.logistics import Learned, Levels

if TYPE_CHECKING:
    from cmdp_pymunk.cases.model import Case
    from cmdp_pymunk.engine import Engine


class ModelLogistics(Levels):
    """The lift head of ``evaluator``'s model as a logistics role: asked at ``shares`` of a
    crane lift, crew i asks for the next lift when the policy's argmax is "lift now".
    ``features``: the lift features (names of ``logistics.LEARNED_FEATURES`` or
    ``material=<name>``, checked against the case in ``prepare``). Keeps no per-episode
    state, so an engine's clones share it, as they share the evaluator."""

    def __init__(self, evaluator, features: tuple[str, ...], shares: tuple[float, ...]):
        # evaluator: the agents.candidates.CandidateModelEvaluator whose model answers (not
        # imported: that module imports this one)
        super().__init__(shares)
        self.evaluator, self.features = evaluator, tuple(features)
        # phi is read as the learned rule reads it (its readers, its checks against the case);
        # its own weights are never used: the model's weights answer
        self._reader = Learned.from_weights(self.features, [0.0] * len(self.features), 0.0,
                                            self.shares)
        self._reader.path = evaluator.path

    def prepare(self, case: Case) -> None:
        super().prepare(case)
        self._reader.prepare(case)  # a material the case lacks: a ValueError naming the fix

    def feature_values(self, engine: Engine, i: int, storage: int) -> tuple[float, ...]:
        """phi at this decision, in ``features`` order (as ``logistics.Learned``'s)."""
        return self._reader.feature_values(engine, i, storage)

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        view = self.evaluator.view
        obs, mask = view.lift_question(engine.site.crews[i].type,
                                       self.feature_values(engine, i, storage))
        action, _ = self.evaluator.model.predict(obs[None], action_masks=mask[None],
                                                 deterministic=True)
        return int(action[0]) == view.cap + 1  # after "run on" (view.cap)


def has_lift_head(spec: str) -> bool:
    """Whether the evaluator spec names a saved model with a lift head (its ``policy_kwargs``
    name ``lift_features``), read from the zip's ``data`` without loading the model: what a
    run's header and ``summary.json`` say decides the lifts under ``--logistics case``."""
    path = Path(spec)
    if path.suffix != ".zip" or not path.is_file():
        return False
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
    except (OSError, KeyError, ValueError, zipfile.BadZipFile):
        return False  # not a saved SB3 model: loading it says why, where it is loaded
    kwargs = data.get("policy_kwargs")
    return isinstance(kwargs, dict) and bool(kwargs.get("lift_features"))


def lifts_decided_by(logistics: str, evaluator: str) -> str:
    """Who asks for the lifts, in words: the ``--logistics`` spec, or under ``case`` with a
    lift-head model the model itself (``make_engine`` gives it the floor's role)."""
    if logistics == "case" and has_lift_head(evaluator):
        return "the evaluator's lift head"
    return logistics
