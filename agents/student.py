"""A target evaluator that starts as the priority heuristic and learns a residual (issue 17).

It re-ranks the ``candidates`` best targets of Eq. 9 by V' + w_type . phi, where phi are the
candidate features of ``agents.features`` and w_type a weight vector per crew type. With every
weight 0 it is exactly Eq. 9 (a test checks it); the weights are fitted to the lookahead's
choices (``training.research.distill``), so it is as cheap to run as Eq. 9 and can be the next
lookahead's base (a step of approximate policy iteration).

Like the lookahead, a choice that overrides Eq. 9 is held until the crew reaches a target or
the target leaves its scope (per site, so one evaluator can serve branches of a floor;
``agents.hold``, shared with masked-choice models saved with ``hold_choice``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from cmdp_pymunk.evaluate import Evaluator, PriorityEvaluator, as_target_values
from cmdp_pymunk.state import ScopeKind

from .features import ALL_FEATURES, FEATURE_NAMES, FloorFacts, candidate_features
from .hold import HeldChoices
from .lookahead import promote, ranked


class StudentEvaluator(Evaluator):
    """Eq. 9 plus a learned residual over its top candidates (see the module doc).

    Args:
        weights: crew type -> one weight per feature in ``features`` (a missing type: zeros).
        candidates: how many of Eq. 9's best targets it may re-rank.
        features: the features the weights are for, each once, from
            ``agents.features.ALL_FEATURES`` (default ``FEATURE_NAMES``, the first eleven).
    """

    def __init__(self, weights: dict[str, list[float]] | None = None, candidates: int = 3,
                 features: tuple[str, ...] = FEATURE_NAMES):
        features = tuple(features)
        unknown = [n for n in features if n not in ALL_FEATURES]
        if unknown or len(set(features)) != len(features) or not features:
            raise ValueError(f"student features {list(features)}: each once, from "
                             f"{', '.join(ALL_FEATURES)}")
        self.features = features
        self.weights = {k: np.asarray(v, dtype=np.float64) for k, v in (weights or {}).items()}
        for crew_type, w in self.weights.items():
            if w.shape != (len(features),):
                raise ValueError(f"student weights for {crew_type!r}: {w.shape[0]} numbers, "
                                 f"expected {len(features)} ({', '.join(features)})")
        self.candidates = candidates
        self.base = PriorityEvaluator()
        self._facts: dict = {}
        self._held = HeldChoices()  # pickles empty

    def __getstate__(self):  # pickled into lookahead workers: the caches stay behind
        state = dict(self.__dict__)
        state["_facts"] = {}
        return state

    def facts(self, site) -> FloorFacts:
        key = id(site.case)
        if key not in self._facts:
            self._facts[key] = FloorFacts.of(site)
        return self._facts[key]

    def values_for(self, engine, i: int) -> dict[int, float]:
        site = engine.site
        crew, position = site.crews[i], engine.positions[i]
        priorities = self.base.priorities(crew, site, position)
        values = as_target_values(priorities)  # Eq. 9's V_Tar, from V' computed once
        held = self._held.values(site, crew, values)  # a hold lasts until a reach
        if held is not None:
            return held
        order = ranked(values)
        top = order[:self.candidates]
        w = self.weights.get(crew.type)
        if crew.scope_kind != ScopeKind.TASKS or len(top) < 2 or w is None or not w.any():
            return values
        phi = candidate_features(self.facts(site), crew, site, position, top, priorities,
                                 engine.positions, self.features)
        scores = np.array([priorities[t] for t in top]) + phi @ w
        choice = top[int(np.argmax(scores))]  # ties: Eq. 9's order
        if choice == order[0]:
            return values
        self._held.hold(site, crew, choice)
        return promote(values, choice)

    # -- files -----------------------------------------------------------------------------------

    def save(self, path: Path, meta: dict) -> None:
        """Weights and how they were made, as JSON (written whole, then moved into place)."""
        data = {"kind": "cmdp-student", "features": list(self.features),
                "candidates": self.candidates,
                "weights": {k: [round(float(x), 6) for x in v] for k, v in self.weights.items()},
                **meta}
        tmp = Path(path).with_suffix(".tmp")
        tmp.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
        tmp.replace(path)

    @classmethod
    def load(cls, path: str | Path) -> StudentEvaluator:
        path = Path(path)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as err:
            raise ValueError(f"--evaluator student:{path}: cannot read it ({err}); give a file "
                             f"written by training.research.distill") from err
        features = data.get("features")
        if data.get("kind") != "cmdp-student" or not isinstance(features, list) or \
                not set(features) <= set(ALL_FEATURES):
            raise ValueError(f"--evaluator student:{path}: not a student file for these features "
                             f"(any of {', '.join(ALL_FEATURES)}); refit it with "
                             "training.research.distill or cmdp-search-rule")
        return cls(data["weights"], data["candidates"], tuple(features))
