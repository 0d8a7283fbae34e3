"""An optimal-schedule reference (beyond the paper): the case as a resource-constrained
project scheduling problem (RCPSP), solved with OR-Tools CP-SAT.

The model, for any case:
- every task is one interval of its expected duration (``cmdp_pymunk.bounds``: Table 3's mean,
  plus the crane's assistance time for a task that needs the crane), in whole seconds rounded
  down (so that the bound stays a bound);
- the crews of each type are a resource of that many units: at most that many tasks of the
  type run at once (``AddCumulative``);
- the crane is one resource: a task that needs it holds it for ``assist_time_s`` at the start
  of its interval (the simulation's crane assists before any work is done; a later assistance
  only lengthens the task, which the relaxation may ignore);
- a task starts when all its predecessors have ended;
- tasks whose areas conflict (the simulation never starts a task whose area overlaps a running
  task's) never overlap in time;
- the makespan is at least ``bounds.lower_bound`` and at least ``resource_cut_s`` (valid cuts:
  CP-SAT alone left its proven bound at the weaker of them for minutes on the built-in case).

Left out, so the optimum is a lower bound on what the simulation can do with expected
durations: walking, fetching materials, the crane's material lifts, waiting in the crane's
queue, congestion and invasion (Eq. 2), and the randomness of durations (the bound is for
expected durations, as ``bounds.lower_bound`` is).

``solve`` returns the proven bound, the best schedule's makespan and whether it is proven
optimal within the time limit. ``PlanEvaluator`` replays the best schedule in the simulator:
a crew prefers the task that the plan starts earliest (``TaskPriorityEvaluator`` with
priority 1 - start / makespan).
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field

from cmdp_pymunk.bounds import expected_duration_s, heads_and_tails, lower_bound

from .task_priority import TaskPriorityEvaluator

DEFAULT_TIME_LIMIT_S = 20.0


@dataclass(frozen=True)
class CpsatResult:
    """CP-SAT's answer: ``bound_s`` is proven (no schedule of the model is shorter);
    ``makespan_s`` is the best schedule found (None if none); ``optimal`` when they meet."""

    status: str
    bound_s: float
    makespan_s: float | None
    optimal: bool
    gap: float | None  # (makespan - bound) / makespan
    wall_s: float
    time_limit_s: float
    workers: int
    starts_s: dict = field(default_factory=dict)  # task id -> planned start

    def as_dict(self, with_plan: bool = False) -> dict:
        data = asdict(self)
        if not with_plan:
            data.pop("starts_s")
        return data


def whole_seconds(seconds: float) -> int:
    """Rounded down, but not below a whole number it misses by float error (0.3 / 0.1 * 60
    is 179.99999999999997)."""
    return int(math.floor(seconds + 1e-6))


def task_conflicts(case) -> list[tuple[int, int]]:
    """Pairs (i < j) of tasks whose areas overlap, as the simulation computes them."""
    from cmdp_pymunk.state import Site

    site = Site(case, 2)
    return sorted({(min(t.index, o), max(t.index, o)) for t in site.tasks for o in t.conflicts})


def conflict_cliques(case) -> list[list[int]]:
    """The maximal cliques of the conflict graph (networkx): tasks that pairwise conflict, so
    at most one of them runs at a time. Every conflicting pair lies in one of them."""
    import networkx as nx

    graph = nx.Graph(task_conflicts(case))
    return sorted(sorted(c) for c in nx.find_cliques(graph))


def heads_tails(case) -> tuple[dict[str, float], dict[str, float]]:
    """Per task: the longest chain of expected durations before its start (head) and after its
    end (tail) in the precedence network (``bounds.heads_and_tails`` at mean-pace durations)."""
    return heads_and_tails(case, {t.id: expected_duration_s(case, t) for t in case.tasks})


def resource_cut_s(case) -> tuple[float, str]:
    """A makespan lower bound per crew type k, with heads and tails:

        max over thresholds (h, q) of  h + W(h, q) / n_k + q,

    W(h, q) the expected work of the type's tasks whose head is at least h and tail at least
    q, n_k its crews: those tasks cannot start before h, their work keeps n_k crews busy for
    at least W / n_k, and whichever ends last is followed by a chain of at least q. Returns
    the best value and its crew type (``bounds.lower_bound``'s per-type term is h = q = 0)."""
    head, tail = heads_tails(case)
    duration = {t.id: expected_duration_s(case, t) for t in case.tasks}
    crews: dict[str, int] = {}
    for crew in case.crews:
        crews[crew.type] = crews.get(crew.type, 0) + 1
    by_type: dict[str, list[str]] = {}
    for t in case.tasks:
        by_type.setdefault(case.task_types[t.type].crew_type, []).append(t.id)
    best, which = 0.0, ""
    for crew_type, ids in by_type.items():
        for h in {head[i] for i in ids}:
            for q in {tail[i] for i in ids}:
                work = sum(duration[i] for i in ids if head[i] >= h and tail[i] >= q)
                if work > 0 and h + work / crews[crew_type] + q > best:
                    best, which = h + work / crews[crew_type] + q, crew_type
    return best, which


def solve(case, time_limit_s: float = DEFAULT_TIME_LIMIT_S, workers: int = 1,
          seed: int = 0) -> CpsatResult:
    """Solve the case's RCPSP (see the module doc) within ``time_limit_s`` wall seconds.

    ``workers`` is CP-SAT's search workers (1: deterministic when it proves optimality within
    the limit; a run cut by the limit may stop at a different point on a slower machine).
    """
    from ortools.sat.python import cp_model

    if not (math.isfinite(time_limit_s) and time_limit_s > 0):
        raise ValueError(f"time_limit_s must be a positive number of seconds, not "
                         f"{time_limit_s!r}")
    tasks = case.tasks
    index = {t.id: i for i, t in enumerate(tasks)}
    duration = [whole_seconds(expected_duration_s(case, t)) for t in tasks]
    horizon = sum(duration) + 1
    m = cp_model.CpModel()
    start = [m.NewIntVar(0, horizon, f"s_{t.id}") for t in tasks]
    end = [m.NewIntVar(0, horizon, f"e_{t.id}") for t in tasks]
    interval = [m.NewIntervalVar(start[i], duration[i], end[i], f"i_{t.id}")
                for i, t in enumerate(tasks)]
    crews = {}
    for crew in case.crews:
        crews[crew.type] = crews.get(crew.type, 0) + 1
    by_type: dict[str, list[int]] = {}
    crane = []
    assist = whole_seconds(case.crane.assist_time_s)
    for i, t in enumerate(tasks):
        tt = case.task_types[t.type]
        by_type.setdefault(tt.crew_type, []).append(i)
        if tt.needs_crane and assist > 0:
            crane.append(m.NewFixedSizeIntervalVar(start[i], assist, f"crane_{t.id}"))
        for p in t.predecessors:
            m.Add(start[i] >= end[index[p]])
    for crew_type, members in by_type.items():
        m.AddCumulative([interval[i] for i in members], [1] * len(members), crews[crew_type])
    if crane:
        m.AddNoOverlap(crane)
    for clique in conflict_cliques(case):  # stronger than one constraint per pair
        m.AddNoOverlap([interval[i] for i in clique])
    makespan = m.NewIntVar(0, horizon, "makespan")
    m.AddMaxEquality(makespan, end)
    cut, _ = resource_cut_s(case)
    m.Add(makespan >= whole_seconds(max(lower_bound(case).lower_bound_s, cut)))
    m.Minimize(makespan)

    solver = cp_model.CpSolver()
    solver.parameters.max_time_in_seconds = float(time_limit_s)
    solver.parameters.num_workers = int(workers)
    solver.parameters.random_seed = int(seed)
    # CP-SAT's default installs its own C SIGINT handler and leaves SIGINT at SIG_DFL after
    # the solve: a later Ctrl-C then killed cmdp-evaluate outright, with no message and its
    # worker processes orphaned. Ctrl-C stays Python's.
    solver.parameters.catch_sigint_signal = False
    t0 = time.perf_counter()
    status = solver.Solve(m)
    wall = time.perf_counter() - t0
    found = status in (cp_model.OPTIMAL, cp_model.FEASIBLE)
    best = float(solver.ObjectiveValue()) if found else None
    bound = float(solver.BestObjectiveBound())
    starts = {t.id: int(solver.Value(start[i])) for i, t in enumerate(tasks)} if found else {}
    return CpsatResult(solver.StatusName(status).lower(), bound, best,
                       status == cp_model.OPTIMAL,
                       (best - bound) / best if best else None, round(wall, 3),
                       float(time_limit_s), int(workers), starts)


def plan_priorities(result: CpsatResult) -> dict[str, float]:
    """Priority 1 - start / makespan per task: the earlier the plan starts it, the higher."""
    if not result.starts_s:
        raise ValueError(f"CP-SAT found no schedule ({result.status}) within "
                         f"{result.time_limit_s:g} s; fix: give it more time")
    span = max(result.makespan_s or 0.0, 1.0)
    return {tid: 1.0 - s / span for tid, s in result.starts_s.items()}


class PlanEvaluator(TaskPriorityEvaluator):
    """Replays the CP-SAT plan: the task the plan starts earliest is preferred. The plan is
    solved for the env's case when first bound (``time_limit_s``), or given (``result``)."""

    def __init__(self, result: CpsatResult | None = None,
                 time_limit_s: float = DEFAULT_TIME_LIMIT_S):
        super().__init__({}, 0.0, "<cpsat plan>")
        self.time_limit_s = time_limit_s
        self.result = None
        if result is not None:
            self.use(result)

    def use(self, result: CpsatResult) -> None:
        self.result = result
        self.priorities = plan_priorities(result)

    def prepare(self, case) -> None:
        if self.result is None:
            self.use(solve(case, self.time_limit_s))
        super().prepare(case)  # a plan for another case: ValueError


def save_plan(path, case, result: CpsatResult):
    """The plan as a priority file (``cmdp-simulate --evaluator cpsat:PATH``), with the
    solver's answer and the planned starts."""
    from .task_priority import save_priorities

    return save_priorities(path, case, plan_priorities(result), 0.0, "cpsat",
                           cpsat=result.as_dict(with_plan=True))
