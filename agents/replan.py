"""A re-planning solver (issue 17, item 2b; beyond the paper): CP-SAT re-solves the rest of
the floor at each decision, and the deciding crew takes the candidate the plan starts first.

The one-shot plan (``cpsat.PlanEvaluator``) is solved once for expected durations and then
replayed blind: it ignores walking, fetching, the crane's queue and everything that happens
after it was made. Here the plan is remade from the floor as it stands whenever a crew must
choose among two or more tasks:

- tasks that have ended are gone; a task in progress is a fixed interval from now until its
  expected end (its remaining work at the pace it was drawn with), holding one unit of its
  crew type, the crane if it still waits for it, and its area (no conflicting task overlaps
  it);
- every task not started is an interval of its expected duration (``bounds``: Table 3's
  mean plus the crane's assistance) plus ``overhead_s``, the walking and fetching a task
  costs on average, which the one-shot plan leaves out;
- precedences, the crews of each type as a cumulative resource, the crane's assistance as
  one machine and the conflict graph's cliques as in ``cpsat.solve``;
- the objective is the makespan first and, below it, the sum of the tasks' ends (weight 1
  against the makespan's n + 1), so that work off the critical path is planned as early as
  it can go and the plan's order among the deciding crew's candidates means something.

The crew then takes, among its scope's tasks, the one the plan starts first (ties: the base
rule's order, Eq. 9 by default), and holds that choice until it reaches the target or the
target leaves its scope (as the lookahead does). Storages and the outlet are the base rule's.

CP-SAT runs on one worker with a *deterministic* time limit (``limit``, in CP-SAT's
deterministic seconds, about wall seconds on this machine), so the same case, seed and
settings give the same schedule on any machine (the house rule); a plan is made at most once
per simulated second and shared by the crews that decide in it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from cmdp_pymunk.bounds import expected_duration_s
from cmdp_pymunk.evaluate import Evaluator
from cmdp_pymunk.precedence import Pool
from cmdp_pymunk.state import ScopeKind

from .cpsat import conflict_cliques, whole_seconds
from .lookahead import promote, ranked
from .priority import PriorityEvaluator


@dataclass(frozen=True)
class ReplanSettings:
    """How the re-planning solver plans.

    Attributes:
        limit: CP-SAT's deterministic time limit per plan (its deterministic seconds).
        overhead_s: expected walking and fetching added to every task not yet started (s).
        window_s: the candidates the plan starts within this many seconds of its first are
            all eligible, and the base rule picks among them (0: the plan's first, ties to
            the base rule).
    """

    limit: float = 1.0
    overhead_s: float = 150.0
    window_s: float = 0.0

    def __post_init__(self):
        if not (isinstance(self.limit, (int, float)) and 0 < self.limit <= 600):
            raise ValueError(f"replan limit must be a number of (deterministic) seconds in "
                             f"(0, 600], not {self.limit!r}")
        if not (isinstance(self.overhead_s, (int, float)) and 0 <= self.overhead_s <= 10_000):
            raise ValueError(f"replan overhead_s must be seconds in [0, 10000], not "
                             f"{self.overhead_s!r}")
        if not (isinstance(self.window_s, (int, float)) and 0 <= self.window_s <= 100_000):
            raise ValueError(f"replan window_s must be seconds in [0, 100000], not "
                             f"{self.window_s!r}")


@dataclass
class Plan:
    """One re-plan: when it was made, the planned start of every task not yet started
    (seconds from then), its makespan from then, CP-SAT's status and its wall time."""

    time_s: float
    starts: dict[int, int]
    makespan_s: float
    status: str
    wall_s: float
    version: int = -1  # the site's version it was made at


def remaining_seconds(task, expected_s: float) -> float:
    """Seconds a task in progress still needs: its remaining work at the pace drawn for it
    (the expected duration's share of the remaining work if no pace is known)."""
    left = max(0.0, task.work - task.progress)
    if task.pace > 0:
        return left / task.pace
    return expected_s * left / task.work if task.work > 0 else 0.0


def solve_rest(site, settings: ReplanSettings, cliques: list[list[int]]) -> Plan:
    """The rest of the floor as a CP-SAT model (see the module doc), solved from now."""
    from ortools.sat.python import cp_model

    case = site.case
    tasks = site.tasks
    expected = [expected_duration_s(case, case.tasks[t.index]) for t in tasks]
    overhead = whole_seconds(settings.overhead_s)
    assist = whole_seconds(case.crane.assist_time_s)
    m = cp_model.CpModel()
    horizon = sum(whole_seconds(e) + overhead for e in expected) + 1
    start, end, interval = {}, {}, {}
    for t in tasks:
        if t.pool == Pool.END:
            continue
        if t.pool == Pool.ON:  # in progress: fixed from now to its expected end
            left = int(round(remaining_seconds(t, expected[t.index])))
            start[t.index] = m.NewConstant(0)
            end[t.index] = m.NewConstant(left)
            interval[t.index] = m.NewIntervalVar(start[t.index], left, end[t.index],
                                                 f"on_{t.id}")
            continue
        size = whole_seconds(expected[t.index]) + overhead
        start[t.index] = m.NewIntVar(0, horizon, f"s_{t.id}")
        end[t.index] = m.NewIntVar(0, horizon, f"e_{t.id}")
        interval[t.index] = m.NewIntervalVar(start[t.index], size, end[t.index], f"i_{t.id}")
    if not interval:
        return Plan(site.time_s, {}, 0.0, "done", 0.0)
    crews: dict[str, int] = {}
    for crew in site.crews:
        crews[crew.type] = crews.get(crew.type, 0) + 1
    by_type: dict[str, list[int]] = {}
    crane = []
    for i in interval:
        t = tasks[i]
        by_type.setdefault(t.crew_type, []).append(i)
        if t.needs_crane and assist > 0 and not t.crane_assisted:
            if t.pool == Pool.ON:  # waiting for its assistance: the crane's next job
                crane.append(m.NewIntervalVar(m.NewConstant(0), assist, m.NewConstant(assist),
                                              f"crane_on_{t.id}"))
            else:
                crane.append(m.NewFixedSizeIntervalVar(start[i], assist, f"crane_{t.id}"))
        if t.pool != Pool.ON:
            for p in t.predecessors:
                if p in end:
                    m.Add(start[i] >= end[p])
    for crew_type, members in by_type.items():
        m.AddCumulative([interval[i] for i in members], [1] * len(members), crews[crew_type])
    if len(crane) > 1:
        m.AddNoOverlap(crane)
    for clique in cliques:
        live = [interval[i] for i in clique if i in interval]
        if len(live) > 1:
            m.AddNoOverlap(live)
    makespan = m.NewIntVar(0, horizon, "makespan")
    m.AddMaxEquality(makespan, list(end.values()))
    # the makespan first; below it, every task as early as it can go
    m.Minimize(makespan * (len(end) + 1) + sum(end.values()))
    solver = cp_model.CpSolver()
    solver.parameters.max_deterministic_time = float(settings.limit)
    solver.parameters.num_workers = 1  # deterministic with a deterministic limit
    solver.parameters.random_seed = 0
    solver.parameters.catch_sigint_signal = False  # Ctrl-C stays Python's (see cpsat.solve)
    t0 = time.perf_counter()
    status = solver.Solve(m)
    wall = time.perf_counter() - t0
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return Plan(site.time_s, {}, float("nan"), solver.StatusName(status).lower(), wall)
    starts = {i: int(solver.Value(start[i])) for i in start if tasks[i].pool != Pool.ON}
    return Plan(site.time_s, starts, float(solver.Value(makespan)),
                solver.StatusName(status).lower(), wall)


class ReplanEvaluator(Evaluator):
    """The re-planning solver as a target evaluator (see the module doc)."""

    def __init__(self, base=None, settings: ReplanSettings | None = None):
        self.base = base if base is not None else PriorityEvaluator()
        self.settings = settings or ReplanSettings()
        self.plans: list[Plan] = []
        self.decisions = 0
        self.overrides = 0
        self._episode = None
        self._cliques: tuple = (None, [])  # (case, its conflict cliques), made once per case
        self._held: dict[int, tuple[int, int]] = {}  # crew -> (target, reaches when chosen)

    def prepare(self, case) -> None:
        self.base.prepare(case)

    def values_for(self, engine, i: int) -> dict[int, float]:
        site = engine.site
        crew = site.crews[i]
        values = self.base.values_for(engine, i)
        if self._episode is not site:  # a new episode (reset builds a new site)
            self._episode, self._held, self.plans = site, {}, []
            self.decisions = self.overrides = 0
            if self._cliques[0] is not site.case:
                self._cliques = (site.case, conflict_cliques(site.case))
        held = self._held.get(crew.index)
        if held is not None:
            target, reaches = held
            if target in values and crew.stats.reaches == reaches:
                return promote(values, target)
            del self._held[crew.index]
        tasks = {t: task for t, task in crew.scope.items() if task >= 0}
        if crew.scope_kind != ScopeKind.TASKS or len(tasks) < 2:
            return values
        # a task another crew already heads for is left to it while others remain
        taken = {target for j, (target, _) in self._held.items() if j != crew.index}
        tasks = {t: task for t, task in tasks.items() if t not in taken} or tasks
        plan = self._plan(site)
        if not plan.starts:  # no schedule within the limit: the base rule decides
            return values
        order = ranked(values)
        first = min(plan.starts.get(task, 1 << 62) for task in tasks.values())
        eligible = [t for t in tasks
                    if plan.starts.get(tasks[t], 1 << 62) <= first + self.settings.window_s]
        choice = min(eligible, key=order.index)  # window 0: the plan's first, ties to the base
        self.decisions += 1
        self.overrides += choice != order[0]
        self._held[crew.index] = (choice, crew.stats.reaches)
        return promote(values, choice)

    def _plan(self, site) -> Plan:
        if self.plans and self.plans[-1].time_s == site.time_s \
                and self.plans[-1].version == site.version:
            return self.plans[-1]
        plan = solve_rest(site, self.settings, self._cliques[1])
        plan.version = site.version
        self.plans.append(plan)
        return plan

    def summary(self) -> dict:
        """Plans made, decisions, how many overrode the base rule, and the solver's wall time."""
        return {"plans": len(self.plans), "decisions": self.decisions,
                "overrides": self.overrides,
                "solver_wall_s": round(sum(p.wall_s for p in self.plans), 2),
                "limit": self.settings.limit, "overhead_s": self.settings.overhead_s,
                "window_s": self.settings.window_s}
