"""The masked choice over a crew's best targets (issue 17, item 3): what the policy reads and
what its choice does, the same in training (``training.candidate_loop``) and deployment
(``CandidateModelEvaluator``).

A decision of a crew with a task scope of two or more targets shows the policy its ``cap``
best targets by Eq. 9 (best first; fewer are padded and masked), one row each: Eq. 9's V' and
the candidate features of ``agents.features`` (``CANDIDATE_COLUMNS``). The action is the index
of the chosen row. Choosing row 0 is Eq. 9's own choice, and leaves Eq. 9's values untouched;
another row swaps that target with Eq. 9's best (``lookahead.promote``), so only the first
choice changes. Scopes of other kinds (storages, the crane) and scopes with a single target
are valued by Eq. 9 without asking the policy.

Typed rows (``typed = true``, ``CandidateView(cap, CREW_TYPES)``): each row also carries a
one-hot of the deciding crew's type over the vocabulary ``CREW_TYPES`` stored in the model
(the paper's five types); a crew of a type outside it gets all-zero type columns, so the
model scores it by its shared terms only (the per-type term is zero for it).

The policy (``agents.candidate_policy``) scores each row as ``scale * V' + r(row)``, ``r`` a
small network shared across rows whose last layer starts at zero: untrained, its argmax is
Eq. 9's choice (row 0 wins ties: torch's argmax takes the first). A model saved with
``hold_choice`` holds a choice other than Eq. 9's until the crew reaches a target or the
target leaves its scope, as the student does (``agents.hold``).

A model with a lift head (``lift_features`` saved with its policy; issue 42 item 6) reads a
lift block after the rows (the lift features, then the crew type's one-hot; zeros in a target
question) and has two more actions after the rows ("run on", "lift now"; masked in a target
question): the same model answers the floor's lift questions (``agents.lift.ModelLogistics``,
``CandidateModelEvaluator.logistics``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cmdp_pymunk.evaluate import Evaluator, PriorityEvaluator, as_target_values
from cmdp_pymunk.logistics import Logistics
from cmdp_pymunk.state import ScopeKind

from .features import FEATURE_NAMES, FloorFacts, candidate_features
from .hold import HeldChoices
from .lookahead import promote, ranked

CANDIDATE_COLUMNS = ("eq9_value",) + FEATURE_NAMES
EQ9_RANGE = (-1.0, 1.5)  # V' with the paper's betas (1, 0.5, -1): from -1 up to 1.5
# the typed rows' vocabulary: the paper's crew types (cmdp_pymunk/cases/precast_floor.toml),
# in a fixed order that a typed model's weights are laid out in
CREW_TYPES = ("JCC", "HIC", "GC", "RC", "FC")
# the lift block's upper bound: its features (stocks in lifts, crews, queued requests) stay
# far below it; they are never clipped, so the lift answer reads them as the rule does
LIFT_HIGH = 100.0
LIFT_ANSWERS = 2  # "run on", "lift now": the actions after the rows of a model with a lift head


def observation_bounds(cap: int, types: int = 0, lift: int = 0
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Low and high of the flat observation (``cap`` rows of ``CANDIDATE_COLUMNS`` and, typed,
    ``types`` one-hot columns of the crew's type): V' in ``EQ9_RANGE``, every feature and type
    column in [0, 1]; with ``lift`` lift features, a lift block after the rows (the features
    in [0, ``LIFT_HIGH``], the type's one-hot in [0, 1])."""
    low = np.zeros((cap, len(CANDIDATE_COLUMNS) + types), np.float32)
    high = np.ones_like(low)
    low[:, 0], high[:, 0] = EQ9_RANGE
    if not lift:
        return low.ravel(), high.ravel()
    block = np.concatenate([np.full(lift, LIFT_HIGH, np.float32), np.ones(types, np.float32)])
    return (np.concatenate([low.ravel(), np.zeros_like(block)]),
            np.concatenate([high.ravel(), block]))


def type_columns(crew_type: str, types: tuple[str, ...]) -> np.ndarray:
    """The one-hot of ``crew_type`` over the vocabulary ``types``; all zeros for a type
    outside it (the model then scores the crew by its shared terms only)."""
    onehot = np.zeros(len(types), np.float32)
    if crew_type in types:
        onehot[types.index(crew_type)] = 1.0
    return onehot


def has_choice(crew) -> bool:
    """Whether the policy is asked: a task scope of two or more targets."""
    return crew.scope_kind == ScopeKind.TASKS and len(crew.scope) > 1


class CandidateView:
    """Builds a decision's rows and turns a chosen row into V_Tar (see the module doc); keeps
    the case-only facts per case. ``types``: the crew-type vocabulary of typed rows
    (``CREW_TYPES``), () for the untyped rows of ``CANDIDATE_COLUMNS`` only. ``lift``: the
    lift head's feature count (0: none; then the observation is the rows alone)."""

    def __init__(self, cap: int, types: tuple[str, ...] = (), lift: int = 0):
        if cap < 2:
            raise ValueError(f"candidates = {cap}: the policy needs at least 2 to choose from")
        self.cap, self.types, self.lift = cap, tuple(types), lift
        self.width = len(CANDIDATE_COLUMNS) + len(self.types)  # floats per row
        # the lift block after the rows, and the two lift answers after the rows' actions
        self.lift_width = lift + len(self.types) if lift else 0
        self.answers = LIFT_ANSWERS if lift else 0
        self.size = cap * self.width + self.lift_width
        self.base = PriorityEvaluator()
        self.low, self.high = observation_bounds(cap, len(self.types))  # the rows' bounds
        self._facts: dict[int, FloorFacts] = {}

    def facts(self, site) -> FloorFacts:
        key = id(site.case)
        if key not in self._facts:
            self._facts[key] = FloorFacts.of(site)
        return self._facts[key]

    def rows(self, crew, site, position, positions) -> CandidateDecision:
        """The decision's flat rows (padded with zeros), which rows are real, the target of
        each (best by Eq. 9 first) and Eq. 9's values of the scope, from one V'."""
        priorities = self.base.priorities(crew, site, position)
        values = as_target_values(priorities)
        order = ranked(values)[:self.cap]
        obs = np.zeros(self.size, np.float32)  # a lift block stays zero in a target question
        rows = obs[:self.cap * self.width]
        table = rows.reshape(self.cap, self.width)
        table[:len(order), 0] = [priorities[t] for t in order]
        table[:len(order), 1:len(CANDIDATE_COLUMNS)] = candidate_features(
            self.facts(site), crew, site, position, order, priorities, positions)
        if self.types:
            table[:len(order), len(CANDIDATE_COLUMNS):] = type_columns(crew.type, self.types)
        np.clip(rows, self.low, self.high, out=rows)
        mask = np.zeros(self.cap + self.answers, bool)  # the lift answers masked
        mask[:len(order)] = True
        return CandidateDecision(obs, mask, order, values)

    def lift_question(self, crew_type: str, phi) -> tuple[np.ndarray, np.ndarray]:
        """A lift question's observation (the rows zero, the lift block ``phi`` and the crew
        type's one-hot, unclipped) and mask (the two answers only)."""
        obs = np.zeros(self.size, np.float32)
        block = obs[self.cap * self.width:]
        block[:self.lift] = phi
        if self.types:
            block[self.lift:] = type_columns(crew_type, self.types)
        mask = np.zeros(self.cap + self.answers, bool)
        mask[self.cap:] = True
        return obs, mask


@dataclass
class CandidateDecision:
    """One decision as the policy sees it (``CandidateView.rows``)."""

    observation: np.ndarray
    mask: np.ndarray
    targets: list[int]
    eq9_values: dict[int, float]

    def values(self, choice: int) -> dict[int, float]:
        """V_Tar for the crew's scope when row ``choice`` is chosen: Eq. 9's values, with
        that target swapped to the top unless it already is."""
        if choice == 0:
            return self.eq9_values
        return promote(self.eq9_values, self.targets[choice])


class CandidateModelEvaluator(Evaluator):
    """A trained masked-choice model (``cmdp-train stage2 --set action=candidate``) as a
    target evaluator: the crew's rows, the policy's argmax over the real ones, its values.

    What the rows are and whether a choice is held come from the policy's saved parameters:
    ``types`` (the crew-type vocabulary of typed rows; () for untyped) and ``hold_choice``
    (hold a choice other than Eq. 9's as the student does, ``agents.hold``); a model saved
    before them has neither and behaves as it always did.

    ``logistics``: with a lift head (``lift_features`` saved with the policy), the logistics
    role the same model plays (``agents.lift.ModelLogistics``; the commands give it to the
    floor unless ``--logistics`` names another role); None without one."""

    def __init__(self, path: str | Path, model=None):
        self.path = Path(path)
        self.model = model if model is not None else load_candidate_model(path)
        policy = self.model.policy
        lift = tuple(getattr(policy, "lift_features", ()))
        cap = self.model.action_space.n - (LIFT_ANSWERS if lift else 0)
        self.view = CandidateView(cap, tuple(getattr(policy, "types", ())), len(lift))
        self.held = HeldChoices() if getattr(policy, "hold_choice", False) else None
        expected = self.view.size
        if self.model.observation_space.shape != (expected,):
            raise ValueError(f"{self.path}: the model reads {self.model.observation_space.shape} "
                             f"floats, expected ({expected},) for {cap} candidates of "
                             f"{self.view.width} columns ({len(CANDIDATE_COLUMNS)} and "
                             f"{len(self.view.types)} crew types) and a lift block of "
                             f"{self.view.lift_width}; fix: retrain it with these features")
        self.logistics = None
        if lift:
            from .lift import ModelLogistics

            self.logistics = ModelLogistics(self, lift, tuple(policy.lift_shares))

    def values_for(self, engine, i: int) -> dict[int, float]:
        site = engine.site
        crew = site.crews[i]
        if self.held is not None:  # first, as the student: a hold outlasts the scope's kind
            held = self.held.values(site, crew, self.view.base.values_for(engine, i))
            if held is not None:
                return held
        if not has_choice(crew):
            return self.view.base.values_for(engine, i)
        decision = self.view.rows(crew, site, engine.positions[i], engine.positions)
        action, _ = self.model.predict(decision.observation[None],
                                       action_masks=decision.mask[None], deterministic=True)
        choice = int(action[0])
        if self.held is not None and choice != 0:
            self.held.hold(site, crew, decision.targets[choice])
        return decision.values(choice)


def is_candidate_model(path: str | Path) -> bool:
    """Whether a model zip holds a masked choice (a Discrete action) rather than a desired
    position; False for anything unreadable (the caller's loader then names the problem)."""
    import json
    import zipfile

    try:
        with zipfile.ZipFile(path) as z:
            data = json.loads(z.read("data"))
    except (OSError, KeyError, ValueError, zipfile.BadZipFile):
        return False
    # the space's class, e.g. "<class 'gymnasium.spaces.discrete.Discrete'>" (a reaching
    # policy's MultiDiscrete lives in spaces.multi_discrete: not a choice)
    return "spaces.discrete.Discrete" in str(data.get("action_space", {}).get(":type:", ""))


def load_candidate_model(path: str | Path):
    """A MaskablePPO zip (sb3-contrib), on the CPU with one torch thread."""
    from sb3_contrib import MaskablePPO

    from .models import load_model

    return load_model(path, MaskablePPO, "MaskablePPO model", "give a .zip written by "
                      "cmdp-train stage2 with action = candidate")


def logistics_of(evaluator) -> Logistics | None:
    """The logistics role an evaluator plays besides its targets (a masked-choice model with a
    lift head: ``agents.lift.ModelLogistics``), or None for every other evaluator."""
    if isinstance(evaluator, CandidateModelEvaluator):
        return evaluator.logistics
    return None
