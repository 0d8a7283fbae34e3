"""The lookahead: one step of policy improvement over a base rule, by branching the floor.

At a crew's decision (a new task scope with two or more candidates), the ``candidates`` best
targets by the base rule (Eq. 9 unless told otherwise) are each tried on branches of the floor
(``Engine.clone``): the crew heads for that target, everything else follows the base rule to
the end of the floor, and the candidate with the lowest mean makespan over the branches wins
(ties go to the base rule's order). Every candidate meets the same ``futures`` sampled
futures (scenario keys: the paces of tasks not yet started are redrawn, those already drawn
are kept), so the comparison is paired. ``futures=0`` branches into the floor's own future:
the lookahead then sees the true durations, an optimistic bound on what one step of
lookahead can gain (issue 17's headroom measurement). ``futures=expected`` branches once per
candidate into the certainty-equivalent future (``streams.EXPECTED``: every task not yet
started at its expected pace): the cost of one sampled future without its sampling noise.

The chosen target is put on top of the base rule's values by swapping it with the base's
first choice, so the values stay the base's set. A crew holds a choice that overrode the base
until it reaches a target or the target leaves its scope; a choice equal to the base's is not
held, so with ``candidates=1`` the floor runs exactly as the base rule (a test checks it).

Its public face beyond ``values_for``: ``candidates_for(engine, i, values)`` (the base's order
and the candidates a decision tries, or None where there is none) and ``decide(engine, i,
values)`` (branch them and choose, a ``Decision``; recorded in ``decisions``, which
``summary`` reads). Whoever wants more of a decision (labels, replays) wraps these from
outside; the lookahead knows nothing of it.

Racing (``race=k``, issue 32 item 3: sequential halving's idea, dropping what is clearly
behind rather than a fixed half): every candidate first meets k futures; a candidate whose
paired mean difference to the best so far is above its 95 % interval (Student's t over the
shared futures) is dropped, the others meet twice as many (the same futures again plus new
ones: still paired), and so on until one candidate is left or the survivors have met
``futures``; the best mean among them is the choice. Candidates clearly behind cost a few
futures, and the budget goes to the close ones. With two candidates it stops early when one
is clearly better; with a single candidate there is no decision (the base rule).

It is an evaluator like the others (``--evaluator lookahead`` in ``cmdp-simulate`` and
``cmdp-evaluate``), asked between whole seconds (``between_seconds``: it branches the floor).
Branches play on the engine alone (``Engine.clone``, then ``rollout.play``) with its own low
level (the scripted navigator unless told another): a low level keeps its per-episode state in
``engine.memory``, so the branch continues the plans of the one that drives the floor.
"""

from __future__ import annotations

import math
import multiprocessing
import pickle
import signal
import time
from dataclasses import dataclass

import numpy as np

from cmdp_pymunk.evaluate import Evaluator
from cmdp_pymunk.eventfloor import WalkMotion, calibration_for
from cmdp_pymunk.observe import ReachingObservations
from cmdp_pymunk.rollout import play
from cmdp_pymunk.state import ScopeKind
from cmdp_pymunk.streams import EXPECTED

from .navigator import Navigator
from .priority import PriorityEvaluator


@dataclass(frozen=True)
class LookaheadSettings:
    """How hard the lookahead looks.

    Attributes:
        candidates: how many of the base rule's best targets are tried (1: the base rule).
        futures: sampled futures per candidate (0: the floor's own, true durations).
        expected_paces: instead of sampled futures, one branch per candidate in which every
            task not yet started works at its expected pace (``futures`` must then be 1).
        unfinished_penalty_s: added to the time reached by a branch that stalls or hits the
            time limit, so that it always loses to one that finishes.
        workers: processes that run the branches of a decision side by side (1: in this
            process); the choices are the same for any number.
        think_on: "same" branches the floor itself (``Engine.clone``); "event" branches an
            event floor built from its state at the decision
            (``engine.clone(motion=WalkMotion(...))``, the case's calibration): the
            lookahead thinks on the event floor, some 50 times cheaper a branch, and acts on
            the floor it values (the pymunk one).
        from_share: the lookahead decides once this share of the floor's tasks has ended
            (the endgame: few tasks are left to draw their paces, so a sampled future varies
            less and a branch is short); before, the base rule decides alone. 0: from the
            start.
    """

    candidates: int = 3
    futures: int = 1
    expected_paces: bool = False
    unfinished_penalty_s: float = 100_000.0
    workers: int = 1
    think_on: str = "same"
    race: int = 0
    from_share: float = 0.0

    def __post_init__(self):
        if not (isinstance(self.candidates, int) and self.candidates >= 1):
            raise ValueError(f"lookahead candidates must be an int >= 1, not "
                             f"{self.candidates!r}")
        if not (isinstance(self.workers, int) and self.workers >= 1):
            raise ValueError(f"lookahead workers must be an int >= 1, not {self.workers!r}")
        if not (isinstance(self.futures, int) and self.futures >= 0):
            raise ValueError(f"lookahead futures must be an int >= 0 (0: the floor's own "
                             f"future), not {self.futures!r}")
        if self.think_on not in ("same", "event"):
            raise ValueError(f"lookahead think_on must be 'same' (branch the floor itself) or "
                             f"'event' (branch event floors built from it), not "
                             f"{self.think_on!r}")
        if not (isinstance(self.race, int) and (self.race == 0 or self.race >= 2)):
            raise ValueError(f"lookahead race must be 0 (off) or an int >= 2 (the first "
                             f"round's futures: an interval needs two), not {self.race!r}")
        if self.race and not (self.futures >= self.race and not self.expected_paces):
            raise ValueError(f"lookahead race={self.race} starts each candidate on that many "
                             f"sampled futures, up to futures={self.futures}: give futures >= "
                             f"race (and sampled futures, not expected)")
        if not (isinstance(self.from_share, (int, float)) and 0.0 <= self.from_share < 1.0):
            raise ValueError(f"lookahead from_share must be in [0, 1) (the share of tasks ended "
                             f"before it decides), not {self.from_share!r}")
        if self.expected_paces and self.futures != 1:
            raise ValueError(f"lookahead with expected paces branches once per candidate: "
                             f"futures must be 1, not {self.futures!r}")


@dataclass
class Decision:
    """One decision the lookahead made: when, who, the candidates with their mean makespans,
    the base rule's choice and the one taken."""

    time_s: float
    crew: int
    candidates: list[int]
    makespans_s: list[float]
    base_choice: int
    choice: int
    wall_s: float
    futures_seen: list[int] | None = None  # per candidate, when racing


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


class LookaheadEvaluator(Evaluator):
    """Rollout over a base rule (see the module doc). ``low_level``: what drives the branches
    (default the scripted ``Navigator``; give the floor's own low level so that branches
    continue its plans)."""

    between_seconds = True

    def __init__(self, base=None, settings: LookaheadSettings | None = None, low_level=None):
        self.base = base if base is not None else PriorityEvaluator()
        self.settings = settings or LookaheadSettings()
        self.low_level = low_level if low_level is not None else Navigator()
        self.decisions: list[Decision] = []  # this episode's (``summary``)
        self._pool = None
        self._episode = None
        self._held: dict[int, tuple[int, int]] = {}  # crew -> (target, reaches when chosen)
        self.calibration = None  # the event floor's, when it thinks there (``prepare``)
        self._thinking = None  # (engine's site and time, the event floor built at them)

    def prepare(self, case) -> None:
        """The base and the branches' low level must fit the case; the
        event floor's calibration is found once (``think_on="event"``)."""
        self.base.prepare(case)
        if self.settings.think_on == "event":
            self.calibration = calibration_for(case)

    def thinking_floor(self, engine):
        """What the branches of this decision are cloned from: the floor itself, or an
        event floor at its state (``think_on``)."""
        if self.settings.think_on == "event" and engine.motion.name != "event":
            return engine.clone(keep_log=False, motion=WalkMotion(self.calibration))
        return engine

    def values_for(self, engine, i: int) -> dict[int, float]:
        """V_Tar for crew i's scope: the base's values, with the lookahead's choice on top."""
        self._follow(engine)
        crew = engine.site.crews[i]
        values = self.base.values_for(engine, i)
        held = self._held.get(i)
        if held is not None:
            target, reaches = held
            if target in values and crew.stats.reaches == reaches:
                return promote(values, target)
            del self._held[i]
        decision = self.decide(engine, i, values)
        if decision is None or decision.choice == decision.base_choice:
            return values
        self._held[i] = (decision.choice, crew.stats.reaches)
        return promote(values, decision.choice)

    def _follow(self, engine) -> None:
        """A new episode (reset builds a new site): no choice held, no decision yet."""
        if self._episode is not engine.site:
            self._episode, self._held, self.decisions = engine.site, {}, []

    def candidates_for(self, engine, i: int, values: dict[int, float]) \
            -> tuple[list[int], list[int]] | None:
        """The base's order of crew i's targets and the candidates tried at its decision; None
        where there is nothing to decide: not a task scope, a single target, or not yet the
        endgame (``from_share``)."""
        site = engine.site
        order = ranked(values)
        candidates = order[:self.settings.candidates]
        if site.crews[i].scope_kind != ScopeKind.TASKS or len(candidates) < 2:
            return None
        if site.tasks_ended < self.settings.from_share * len(site.tasks):
            return None  # not yet the endgame: the base decides
        return order, candidates

    def decide(self, engine, i: int, values: dict[int, float]) -> Decision | None:
        """Branch the base's best candidates for crew i (``values``: the base's) and record
        the decision (None where there is nothing to choose: not a task scope, a single
        target, not yet the endgame). It does not hold the choice: ``values_for`` does."""
        self._follow(engine)
        site = engine.site
        tried = self.candidates_for(engine, i, values)
        if tried is None:
            return None
        order, candidates = tried
        start = time.perf_counter()
        seen = None
        if self.settings.race:
            makespans, seen, alive = self._race(engine, i, values, candidates)
        else:
            alive = candidates
            if self.settings.workers > 1:
                makespans = self._parallel_makespans(engine, i, values, candidates)
            else:
                makespans = [self._mean_makespan(engine, i, values, c) for c in candidates]
        choice = min(alive, key=lambda c: (makespans[candidates.index(c)],
                                           candidates.index(c)))
        decision = Decision(site.time_s, i, candidates, makespans, order[0], choice,
                            time.perf_counter() - start, seen)
        self.decisions.append(decision)
        return decision

    # -- branches ------------------------------------------------------------------------------

    def scenarios(self) -> list[int | None]:
        """The futures of this decision: the same for every candidate, new for each decision."""
        k = self.settings.futures
        if self.settings.expected_paces:
            return [EXPECTED]
        if k == 0:
            return [None]
        first = len(self.decisions) * k
        return list(range(first, first + k))

    def _race(self, engine, i: int, values: dict[int, float],
              candidates: list[int]) -> tuple[list[float], list[int], list[int]]:
        """Racing over ``candidates`` (module doc): each candidate's mean makespan over the
        futures it met, how many it met, and the last round's survivors."""
        futures = self.scenarios()  # the decision's futures, a prefix of them per round
        met: dict[int, list[float]] = {c: [] for c in candidates}
        alive, k = list(candidates), self.settings.race
        while True:
            k = min(k, len(futures))
            for c in alive:
                met[c] += [self.branch_makespan(engine, i, values, c, s)
                           for s in futures[len(met[c]):k]]
            alive = [c for c in alive if not clearly_behind(met[c], alive, met)]
            if len(alive) == 1 or k == len(futures):
                break
            k *= 2
        return ([sum(met[c]) / len(met[c]) for c in candidates],
                [len(met[c]) for c in candidates], alive)

    def _mean_makespan(self, engine, i: int, values: dict[int, float], target: int) -> float:
        return sum(self.branch_makespan(engine, i, values, target, s)
                   for s in self.scenarios()) / max(1, self.settings.futures)

    def branch_makespan(self, engine, i: int, values: dict[int, float], target: int,
                        scenario: int | None) -> float:
        """The floor's makespan when crew i heads for ``target`` now and the base rule decides
        everything after, on a branch with future ``scenario``."""
        branch = self._source(engine).clone(scenario, keep_log=False)
        return run_branch(branch, self.low_level, self.base, i, values, target,
                          self.settings.unfinished_penalty_s)

    def _source(self, engine):
        """``thinking_floor`` built once per decision (every candidate and future of it)."""
        if self.settings.think_on != "event":
            return engine
        key = (engine.site.time_s, tuple(engine.pending))
        held = self._thinking
        if held is None or held[0] is not engine.site or held[1] != key:
            self._thinking = held = (engine.site, key, self.thinking_floor(engine))
        return held[2]

    def _parallel_makespans(self, engine, i: int, values: dict[int, float],
                            candidates: list[int]) -> list[float]:
        """Every (candidate, future) branch in the worker processes: the floor is pickled
        once per decision (its event log left out) and each worker rebuilds it."""
        source = self._source(engine)
        branch = source.clone(source.streams.scenario, keep_log=False)
        branch.evaluator = self.base  # so the pickle holds no lookahead (nor its pool)
        blob = pickle.dumps(branch, protocol=pickle.HIGHEST_PROTOCOL)
        futures = self.scenarios()
        jobs = [(blob, self.low_level, i, values, target, scenario, self.base,
                 self.settings.unfinished_penalty_s)
                for target in candidates for scenario in futures]
        results = self._workers().map(_branch_job, jobs, chunksize=1)
        k = len(futures)
        return [sum(results[n * k:(n + 1) * k]) / k for n in range(len(candidates))]

    def _workers(self):
        if self._pool is None:
            ctx = multiprocessing.get_context("spawn")  # no forked torch or pygame state
            self._pool = ctx.Pool(self.settings.workers, _quiet_worker)
        return self._pool

    def close(self) -> None:
        """Stop the worker processes (if any); the evaluator can still be used after."""
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None

    def __getstate__(self):  # a pool does not pickle; a copy starts its own
        state = dict(self.__dict__)
        state["_pool"] = None
        state["_thinking"] = None
        return state

    # -- what it did ----------------------------------------------------------------------------

    def summary(self) -> dict:
        """Decisions taken, how many overrode the base rule, and the wall time they took."""
        d = self.decisions
        return {"decisions": len(d), "overrides": sum(x.choice != x.base_choice for x in d),
                "wall_s": round(math.fsum(x.wall_s for x in d), 2),
                "candidates": self.settings.candidates,
                "futures": "expected" if self.settings.expected_paces else self.settings.futures,
                "thinks_on": self.settings.think_on, "race": self.settings.race,
                "branches": sum(sum(x.futures_seen) if x.futures_seen is not None
                                else len(x.candidates) * max(1, self.settings.futures)
                                for x in d)}


def clearly_behind(mine: list[float], alive: list[int], met: dict[int, list[float]]) -> bool:
    """Whether a candidate's makespans (``mine``, over the first futures) are clearly worse
    than the best surviving candidate's on the same futures: the paired mean difference is
    above Student's t 95 % interval (two-sided) around 0."""
    from scipy.stats import t as student_t

    n = len(mine)
    best = min(alive, key=lambda c: sum(met[c][:n]) / n)
    diffs = np.subtract(mine, met[best][:n])
    if n < 2 or not diffs.any():
        return False
    half = student_t.ppf(0.975, n - 1) * diffs.std(ddof=1) / math.sqrt(n)
    return bool(diffs.mean() > half)


def run_branch(branch, low_level, base, i: int, values: dict[int, float], target: int,
               unfinished_penalty_s: float) -> float:
    """Play a branch (an engine cloned at crew i's decision) to its end with ``low_level``:
    crew i heads for ``target``, the other crews waiting for values get the base rule's, and
    the base rule decides after."""
    branch.evaluator = base  # the branch follows the base rule from here on
    branch.set_target_values(i, promote(values, target))
    for j in list(branch.pending):
        branch.set_target_values(j, base.values_for(branch, j))
    reaching = ReachingObservations(branch.case) if low_level.reads_rays else None
    play(branch, low_level, reaching)
    if branch.makespan_s is not None:
        return branch.makespan_s
    return branch.site.time_s + unfinished_penalty_s


def _branch_job(args) -> float:
    blob, low_level, i, values, target, scenario, base, penalty = args
    branch = pickle.loads(blob)
    if scenario is not None:
        branch.streams.with_scenario(scenario)
    return run_branch(branch, low_level, base, i, values, target, penalty)


def _quiet_worker() -> None:
    """Workers leave Ctrl-C to the main process (which stops them)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
