"""The lookahead: one step of policy improvement over a base rule, by branching the floor.

At a crew's decision (a new task scope with two or more candidates), the ``candidates`` best
targets by the base rule (Eq. 9 unless told otherwise) are each tried on branches of the floor
(``Engine.clone``): the crew heads for that target, everything else follows the base rule to
the end of the floor, and the candidate with the lowest mean makespan over the branches wins
(ties go to the base rule's order). Every candidate meets the same ``futures`` sampled
futures (scenario keys: the paces of tasks not yet started are redrawn, those already drawn
are kept), so the comparison is paired. ``futures=0`` branches into the floor's own future:
the lookahead then sees the true durations, an optimistic bound on what one step of
lookahead can gain (issue 17's headroom measurement).

The chosen target is put on top of the base rule's values by swapping it with the base's
first choice, so the values stay the base's set. A crew holds a choice that overrode the base
until it reaches a target or the target leaves its scope; a choice equal to the base's is not
held, so with ``candidates=1`` the floor runs exactly as the base rule (a test checks it).

It is an evaluator like the others (``--evaluator lookahead`` in ``cmdp-simulate`` and
``cmdp-evaluate``), asked between whole seconds (``evaluate.BranchingEvaluator``), and it
branches the low level with the floor when it is bound to one (``bind_low_level``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from cmdp_pymunk.state import ScopeKind

from .navigator import Navigator
from .priority import PriorityEvaluator


@dataclass(frozen=True)
class LookaheadSettings:
    """How hard the lookahead looks.

    Attributes:
        candidates: how many of the base rule's best targets are tried (1: the base rule).
        futures: sampled futures per candidate (0: the floor's own, true durations).
        unfinished_penalty_s: added to the time reached by a branch that stalls or hits the
            time limit, so that it always loses to one that finishes.
    """

    candidates: int = 3
    futures: int = 1
    unfinished_penalty_s: float = 100_000.0

    def __post_init__(self):
        if not (isinstance(self.candidates, int) and self.candidates >= 1):
            raise ValueError(f"lookahead candidates must be an int >= 1, not "
                             f"{self.candidates!r}")
        if not (isinstance(self.futures, int) and self.futures >= 0):
            raise ValueError(f"lookahead futures must be an int >= 0 (0: the floor's own "
                             f"future), not {self.futures!r}")


@dataclass
class Decision:
    """One decision the lookahead made: when, who, the candidates with their mean makespans,
    the base rule's choice and the one taken (labels for distillation)."""

    time_s: float
    crew: int
    candidates: list[int]
    makespans_s: list[float]
    base_choice: int
    choice: int
    wall_s: float


def promote(values: dict[int, float], target: int) -> dict[int, float]:
    """``values`` with ``target`` swapped with the best one (the base's ranking otherwise)."""
    best = max(values, key=lambda t: (values[t], -t))
    if best == target:
        return dict(values)
    out = dict(values)
    out[best], out[target] = values[target], values[best]
    return out


def ranked(values: dict[int, float]) -> list[int]:
    """Targets best first, in ``steering.best_target``'s order (lowest index on ties)."""
    return sorted(values, key=lambda t: (-values[t], t))


class LookaheadEvaluator:
    """Rollout over a base rule (see the module doc)."""

    between_seconds = True

    def __init__(self, base=None, settings: LookaheadSettings | None = None):
        self.base = base if base is not None else PriorityEvaluator()
        self.settings = settings or LookaheadSettings()
        self.env = None
        self.navigator = None
        self.decisions: list[Decision] = []
        self.on_decision = None  # f(engine, i, values, decision): labels for distillation
        self._episode = None
        self._held: dict[int, tuple[int, int]] = {}  # crew -> (target, reaches when chosen)

    def bind(self, env) -> None:
        """The env whose floor is branched (its engine is what ``values_for`` is given)."""
        self.env = env

    def bind_low_level(self, navigator) -> None:
        """The low level that drives the floor: branches continue with a copy of it."""
        self.navigator = navigator

    def target_values(self, crew, site, position) -> dict[int, float]:
        """The base rule's values (where a plain evaluator is asked)."""
        return self.base.target_values(crew, site, position)

    def values_for(self, engine, i: int) -> dict[int, float]:
        """V_Tar for crew i's scope: the base's values, with the lookahead's choice on top."""
        site = engine.site
        if self._episode is not site:  # a new episode (reset builds a new site)
            self._episode, self._held, self.decisions = site, {}, []
        crew = site.crews[i]
        values = self.base.target_values(crew, site, engine.positions[i])
        held = self._held.get(i)
        if held is not None:
            target, reaches = held
            if target in values and crew.stats.reaches == reaches:
                return promote(values, target)
            del self._held[i]
        order = ranked(values)
        candidates = order[:self.settings.candidates]
        if crew.scope_kind != ScopeKind.TASKS or len(candidates) < 2:
            return values
        start = time.perf_counter()
        makespans = [self._mean_makespan(engine, i, values, c) for c in candidates]
        choice = min(candidates, key=lambda c: (makespans[candidates.index(c)],
                                                candidates.index(c)))
        decision = Decision(site.time_s, i, candidates, makespans, order[0], choice,
                            time.perf_counter() - start)
        self.decisions.append(decision)
        if self.on_decision is not None:
            self.on_decision(engine, i, values, decision)
        if choice == order[0]:
            return values
        self._held[i] = (choice, crew.stats.reaches)
        return promote(values, choice)

    # -- branches ------------------------------------------------------------------------------

    def scenarios(self) -> list[int | None]:
        """The futures of this decision: the same for every candidate, new for each decision."""
        k = self.settings.futures
        if k == 0:
            return [None]
        first = len(self.decisions) * k
        return list(range(first, first + k))

    def _mean_makespan(self, engine, i: int, values: dict[int, float], target: int) -> float:
        return sum(self.branch_makespan(engine, i, values, target, s)
                   for s in self.scenarios()) / max(1, self.settings.futures)

    def branch_makespan(self, engine, i: int, values: dict[int, float], target: int,
                        scenario: int | None) -> float:
        """The floor's makespan when crew i heads for ``target`` now and the base rule decides
        everything after, on a branch with future ``scenario``."""
        env = self.env
        if env is None or env.engine is not engine:
            raise RuntimeError("LookaheadEvaluator: bind(env) to the env whose engine it "
                               "values before running an episode")
        companions = (env,) if self.navigator is None else (env, self.navigator)
        branch_engine, branch_env, *rest = engine.clone(scenario, companions, keep_log=False)
        navigator = rest[0] if rest else Navigator(branch_env)
        branch_env.evaluator = self.base  # the branch follows the base rule from here on
        branch_engine.set_target_values(i, promote(values, target))
        for j in list(branch_engine.pending):
            crew = branch_engine.site.crews[j]
            branch_engine.set_target_values(j, self.base.target_values(
                crew, branch_engine.site, branch_engine.positions[j]))
        while branch_env.agents:
            branch_env.step(navigator.actions(branch_env, None))
        if branch_engine.makespan_s is not None:
            return branch_engine.makespan_s
        return branch_engine.site.time_s + self.settings.unfinished_penalty_s

    # -- what it did ----------------------------------------------------------------------------

    def summary(self) -> dict:
        """Decisions taken, how many overrode the base rule, and the wall time they took."""
        d = self.decisions
        return {"decisions": len(d), "overrides": sum(x.choice != x.base_choice for x in d),
                "wall_s": round(math.fsum(x.wall_s for x in d), 2),
                "candidates": self.settings.candidates, "futures": self.settings.futures}

