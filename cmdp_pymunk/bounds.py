"""A makespan lower bound for any case, so that every result reads as a ratio to it.

The bound is the longer of
- the critical path through the precedence network with expected task durations, and
- per crew type, the total expected work of its tasks divided by the number of its crews.

A task's expected duration is its work at the mean of Table 3 (a duration crew's mean
duration; an efficiency crew's work over its mean efficiency), plus the crane's assistance
time for a task that needs the crane (the crew cannot progress while it waits for it). Walking,
fetching, waiting for the crane's queue and congestion are all left out: they are the room a
strategy has to play with.

That bound reasons at the mean pace. Two facts of the floor make it loose (issue 32):
- **Jensen.** A pace is drawn once per task from a normal clipped at 10 % of its mean
  (``construct.pace_of``), so an efficiency crew's expected time is E[work / efficiency],
  longer than work / E[efficiency] (``expected_task_duration_s``).
- **Loading.** A crew that uses material acquires it at its storage at the material's rate,
  and it cannot task meanwhile (``loading_s``).
``expected_work_by_crew_type`` adds both; ``seed_lower_bound`` bounds the floor of one seed from
the paces it will draw (the same streams and the same draw), its loading and its precedence: the
critical path, and per crew type the time before any of its tasks can start (head), its work
over its crews, and the time the floor runs on after its last task (tail).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import lru_cache

from .cases.model import Case, CrewType

PACE_FLOOR_SHARE = 0.1  # construct.MIN_PACE_SHARE: a draw below 10 % of the mean is clipped


@dataclass(frozen=True)
class LowerBound:
    critical_path_s: float
    critical_path: tuple[str, ...]
    per_crew_type_s: dict
    lower_bound_s: float

    def as_dict(self) -> dict:
        return asdict(self)


def expected_duration_s(case: Case, task) -> float:
    """Expected duration of one task at Table 3's mean (plus crane assistance if it needs it)."""
    tt = case.task_types[task.type]
    seconds = case.crew_types[tt.crew_type].mean_seconds(task.work)
    return seconds + (case.crane.assist_time_s if tt.needs_crane else 0.0)


@lru_cache(maxsize=1024)  # a handful of crew types a case, asked once per task
def clipped_normal_mean(mean: float, sd: float, floor: float) -> float:
    """E[max(X, floor)] for X ~ N(mean, sd), in closed form: floor * Phi(a) + mean * (1 -
    Phi(a)) + sd * phi(a) with a = (floor - mean) / sd. A duration crew's expected duration:
    its draw is clipped below at ``floor``, which lifts the mean a little where sd is large."""
    if sd <= 0.0:
        return max(mean, floor)
    # scipy.stats here, not at the top: every case load imports this module
    # (cases.time_checks), and scipy.stats took a second of every command's start (and of
    # each worker's) that never asks for this bound
    from scipy import stats

    a = (floor - mean) / sd
    return float(floor * stats.norm.cdf(a) + mean * stats.norm.sf(a) + sd * stats.norm.pdf(a))


@lru_cache(maxsize=1024)  # a numerical integral: every task of a crew type asks the same
def clipped_normal_inverse_mean(mean: float, sd: float, floor: float) -> float:
    """E[1 / max(X, floor)] for X ~ N(mean, sd), by numerical integration: Phi(a) / floor (the
    clipped mass) + the integral of pdf(x) / x from ``floor`` up. An efficiency crew's time per
    unit of work is 1 / its drawn efficiency, and by Jensen its mean exceeds 1 / mean."""
    if sd <= 0.0:
        return 1.0 / max(mean, floor)
    from scipy import integrate, stats  # here, not at the top: see clipped_normal_mean

    clipped = float(stats.norm.cdf((floor - mean) / sd)) / floor
    upper = mean + 12.0 * sd  # beyond it the normal's mass is below 1e-32
    if upper <= floor:
        return clipped
    tail, _ = integrate.quad(lambda x: stats.norm.pdf(x, mean, sd) / x, floor, upper,
                             points=[mean] if floor < mean < upper else None, limit=200)
    return clipped + float(tail)


def expected_seconds(spec: CrewType, work: float) -> float:
    """Expected working time for ``work`` units under the pace law ``construct.pace_of``
    draws (normal, clipped at 10 % of the mean): E[work / pace], not work / E[pace]."""
    if spec.by_duration:
        mean, sd = spec.duration_mean_min, spec.duration_sd_min or 0.0
        return work * 60.0 * clipped_normal_mean(mean, sd, PACE_FLOOR_SHARE * mean)
    mean, sd = spec.efficiency_mean_per_min, spec.efficiency_sd_per_min or 0.0
    return work * 60.0 * clipped_normal_inverse_mean(mean, sd, PACE_FLOOR_SHARE * mean)


def jensen_ratio(spec: CrewType) -> float:
    """Expected time over the time at the mean pace, for one crew type (1 for a duration crew
    whose clip lies far below its mean; about 1.19 for the built-in case's reinforcing crews)."""
    return expected_seconds(spec, 1.0) / spec.mean_seconds(1.0)


def expected_task_duration_s(case: Case, task) -> float:
    """Expected duration of one task under the drawn pace law (Jensen), plus crane assistance
    if it needs it; ``expected_duration_s`` is the same at the mean pace."""
    tt = case.task_types[task.type]
    seconds = expected_seconds(case.crew_types[tt.crew_type], task.work)
    return seconds + (case.crane.assist_time_s if tt.needs_crane else 0.0)


def loading_s(case: Case, task) -> float:
    """Seconds the task's crew spends acquiring its material at the storage: its quantity over
    the material's acquisition rate (``construct._fetch``; invading crews only slow it). The
    crew is fetching, not tasking, meanwhile, so the time adds to its crew type's work."""
    material = case.task_types[task.type].material
    if material is None or task.material_quantity <= 0.0:
        return 0.0
    return task.material_quantity / case.materials[material].acquire_per_min * 60.0


def in_task_loading_s(case: Case, task) -> float:
    """Loading that must fall between the task's start and its end: a crew starts a task with at
    most its carry capacity, so the rest of the quantity is fetched while the task is on (on the
    critical path; the first load can be fetched before the predecessors end)."""
    material = case.task_types[task.type].material
    if material is None:
        return 0.0
    capacity = case.crew_types[case.task_types[task.type].crew_type].carry_capacity
    rest = max(0.0, task.material_quantity - capacity)
    return rest / case.materials[material].acquire_per_min * 60.0


def crews_by_type(case: Case) -> dict[str, int]:
    """How many crews each crew type has on the floor."""
    count: dict[str, int] = {}
    for crew in case.crews:
        count[crew.type] = count.get(crew.type, 0) + 1
    return count


def work_per_crew(case: Case, seconds: dict[str, float]) -> dict[str, float]:
    """Each crew type's total of ``seconds`` (task id -> s) over its tasks, per crew: a crew type
    cannot finish before its crews have done it all, shared at best evenly."""
    crews = crews_by_type(case)
    total: dict[str, float] = {}
    for t in case.tasks:
        ct = case.task_types[t.type].crew_type
        total[ct] = total.get(ct, 0.0) + seconds[t.id]
    return {ct: w / max(1, crews.get(ct, 0)) for ct, w in total.items()}


def expected_work_by_crew_type(case: Case) -> dict[str, float]:
    """Expected seconds of work per crew of each type: task time under the pace law (Jensen)
    plus loading, over the type's crews. The largest names the floor's bottleneck."""
    return work_per_crew(case, {t.id: expected_task_duration_s(case, t) + loading_s(case, t)
                                for t in case.tasks})


def critical_path(case: Case, duration: dict[str, float]) -> tuple[float, tuple[str, ...]]:
    """The longest chain through the precedence network at the given durations (task id -> s):
    its length and its tasks, first to last."""
    finish: dict[str, float] = {}
    via: dict[str, str | None] = {}
    preds = {t.id: t.predecessors for t in case.tasks}

    def earliest_finish(tid: str) -> float:  # iterative: deep precedence chains are fine
        stack = [tid]
        while stack:
            node = stack[-1]
            todo = [p for p in preds[node] if p not in finish]
            if todo:
                stack.extend(todo)
                continue
            stack.pop()
            if node not in finish:
                best = max(preds[node], key=lambda p: finish[p], default=None)
                via[node] = best
                finish[node] = duration[node] + (finish[best] if best else 0.0)
        return finish[tid]

    end = max(case.tasks, key=lambda t: earliest_finish(t.id)).id
    path = [end]
    while via[path[-1]] is not None:
        path.append(via[path[-1]])
    return finish[end], tuple(reversed(path))


@dataclass(frozen=True)
class SeedBound:
    """A bound on the makespan of the floor drawn with one seed (``seed_lower_bound``):
    ``per_crew_type_s`` is head + work over crews + tail per crew type (``crew_type_bound_s``),
    ``binding`` the term that gives ``seed_bound_s``."""

    seed: int
    critical_path_s: float
    critical_path: tuple[str, ...]
    per_crew_type_s: dict
    binding: str  # "critical_path" or the crew type whose work per crew is the bound
    seed_bound_s: float

    def as_dict(self) -> dict:
        return asdict(self)


def drawn_durations_s(case: Case, seed: int) -> dict[str, float]:
    """Each task's working time on the floor of ``seed``: its work over the pace it will draw
    (the task's own stream, ``RandomStreams(seed).pace(index)``, and ``construct.pace_of``: the
    very draw the engine makes when the task starts), plus crane assistance if it needs it."""
    from .construct import pace_of  # the simulation stage; cases.time_checks imports this module
    from .streams import RandomStreams

    streams = RandomStreams(seed)
    out = {}
    for index, t in enumerate(case.tasks):
        tt = case.task_types[t.type]
        pace = pace_of(streams.pace(index), case.crew_types[tt.crew_type])
        out[t.id] = t.work / pace + (case.crane.assist_time_s if tt.needs_crane else 0.0)
    return out


def heads_and_tails(case: Case, duration: dict[str, float]) -> tuple[dict, dict]:
    """Per task at the given durations (task id -> s): its head, the earliest it can start (the
    longest chain of predecessors), and its tail, the least time the floor runs on after it
    ends (the longest chain of successors)."""
    succs: dict[str, list[str]] = {t.id: [] for t in case.tasks}
    indegree = {t.id: len(t.predecessors) for t in case.tasks}
    for t in case.tasks:
        for p in t.predecessors:
            succs[p].append(t.id)
    order = [t.id for t in case.tasks if not t.predecessors]
    for tid in order:  # grows while it is read: a topological order
        for s in succs[tid]:
            indegree[s] -= 1
            if indegree[s] == 0:
                order.append(s)
    preds = {t.id: t.predecessors for t in case.tasks}
    head: dict[str, float] = {}
    for tid in order:
        head[tid] = max((head[p] + duration[p] for p in preds[tid]), default=0.0)
    tail: dict[str, float] = {}
    for tid in reversed(order):
        tail[tid] = max((duration[s] + tail[s] for s in succs[tid]), default=0.0)
    return head, tail


def preload_s(case: Case, crew_type: str) -> float:
    """Loading a crew of this type can do before its first task: one full carry (its capacity
    over its material's rate; the slowest material's if it has several). A crew carries no more,
    so the rest of its loading falls after its first task can start."""
    rates = [case.materials[tt.material].acquire_per_min for tt in case.task_types.values()
             if tt.crew_type == crew_type and tt.material]
    if not rates:
        return 0.0
    return case.crew_types[crew_type].carry_capacity / min(rates) * 60.0


def crew_type_bound_s(head_s: float, work_s: float, crews: int, preload: float,
                      tail_s: float) -> float:
    """Head + body + tail for one crew type: none of its tasks starts before ``head_s`` (the
    least head of its tasks); its ``work_s`` (task time and loading) less what its ``crews`` can
    preload is shared at best evenly; the floor runs at least ``tail_s`` (the least tail of its
    tasks) after its last task ends."""
    return head_s + max(0.0, work_s - crews * preload) / crews + tail_s


def seed_lower_bound(case: Case, seed: int) -> SeedBound:
    """A lower bound on the makespan of the floor of ``seed`` (no disruptions), without running
    it, from the durations its tasks will draw (the loading a task's crew must do while it is on
    counts in its duration): the longer of the critical path and, per crew type, head + its task
    time and loading over its crews + tail (``crew_type_bound_s``). Unlike ``lower_bound`` (at
    the mean pace), no run of this seed can beat it."""
    drawn = drawn_durations_s(case, seed)
    duration = {t.id: drawn[t.id] + in_task_loading_s(case, t) for t in case.tasks}
    cp, path = critical_path(case, duration)
    head, tail = heads_and_tails(case, duration)
    crews = crews_by_type(case)
    work: dict[str, float] = {}
    first: dict[str, float] = {}
    last: dict[str, float] = {}
    for t in case.tasks:
        ct = case.task_types[t.type].crew_type
        work[ct] = work.get(ct, 0.0) + drawn[t.id] + loading_s(case, t)
        first[ct] = min(first.get(ct, math.inf), head[t.id])
        last[ct] = min(last.get(ct, math.inf), tail[t.id])
    per_type = {ct: crew_type_bound_s(first[ct], w, max(1, crews.get(ct, 0)),
                                      preload_s(case, ct), last[ct])
                for ct, w in work.items()}
    worst = max(per_type, key=lambda ct: (per_type[ct], ct))
    binding = worst if per_type[worst] > cp else "critical_path"
    return SeedBound(seed, cp, path, per_type, binding, max(cp, per_type[worst]))


def lower_bound(case: Case) -> LowerBound:
    """The mean-pace bound: the critical path at ``expected_duration_s`` and each crew type's
    work at the mean pace per crew, the longer (a rough yardstick, not a bound on one seed's
    floor: see ``seed_lower_bound``)."""
    duration = {t.id: expected_duration_s(case, t) for t in case.tasks}
    cp, path = critical_path(case, duration)
    crews_of = crews_by_type(case)
    work: dict[str, float] = {}
    for t in case.tasks:
        ct = case.task_types[t.type].crew_type
        work[ct] = work.get(ct, 0.0) + duration[t.id]
    per_type = {ct: w / crews_of[ct] for ct, w in work.items()}
    return LowerBound(cp, path, per_type, max(cp, *per_type.values()))
