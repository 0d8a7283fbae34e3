"""A makespan lower bound for any case, so that every result reads as a ratio to it.

The bound is the longer of
- the critical path through the precedence network with expected task durations, and
- per crew type, the total expected work of its tasks divided by the number of its crews.

A task's expected duration is its work at the mean of Table 3 (a duration crew's mean
duration; an efficiency crew's work over its mean efficiency), plus the crane's assistance
time for a task that needs the crane (the crew cannot progress while it waits for it). Walking,
fetching, waiting for the crane's queue and congestion are all left out: they are the room a
strategy has to play with.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from .cases.model import Case


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


def lower_bound(case: Case) -> LowerBound:
    duration = {t.id: expected_duration_s(case, t) for t in case.tasks}
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
    crews_of = {}
    for crew in case.crews:
        crews_of[crew.type] = crews_of.get(crew.type, 0) + 1
    work: dict[str, float] = {}
    for t in case.tasks:
        ct = case.task_types[t.type].crew_type
        work[ct] = work.get(ct, 0.0) + duration[t.id]
    per_type = {ct: w / crews_of[ct] for ct, w in work.items()}
    cp = finish[end]
    return LowerBound(cp, tuple(reversed(path)), per_type, max(cp, *per_type.values()))
