"""Where the time goes: each crew type's crew-seconds by what it was doing, in each phase of
the floor, read from the event log alone (its ``activity`` events, the categories of the
agents' Gantt chart, Fig. 9, and its ``task_finish`` events).

Categories (``CATEGORIES``, from ``state.activity``): working (tasking), loading (fetching
material at a storage), walking (reaching a target), idle for predecessors, idle blocked by
task areas, waiting for the crane, disrupted (a disruption kept the crew from working), no
target (nothing of its type left to do, or nothing open yet that it may take), gone (left the
plane). Phases (``phase_bounds``): ramp-up until ``RAMP_UP`` of the tasks have ended, the
middle, and the tail after ``TAIL`` of them: the floor's start behind the joint and hoisting
chain and its end, where a crew type has nothing left, are mostly unavoidable; the middle is
where a scheduler can win time.
"""

from __future__ import annotations

from collections.abc import Sequence

from .events import Event
from .state import DISRUPTED_ACTIVITIES

CATEGORIES: dict[str, tuple[str, ...]] = {
    "working": ("tasking",),
    "loading": ("fetching",),
    "walking": ("navigating",),
    "idle_predecessor": ("idle_predecessor",),
    "idle_area": ("idle_area",),
    "waiting_crane": ("waiting",),
    "disrupted": DISRUPTED_ACTIVITIES,
    "no_target": ("idle_no_target",),
    "gone": ("deregistered", "left"),
}
CATEGORY_OF = {a: c for c, acts in CATEGORIES.items() for a in acts}
# The categories in a planner's words, not the code's: time_use.png's legend and the what-if's
# and summaries' "Where the time goes" tables (the CSV and JSON keep the keys above).
CATEGORY_WORDS = {
    "working": "working on a task",
    "loading": "loading material at a storage",
    "walking": "walking to a target",
    "idle_predecessor": "idle: waiting for a predecessor",
    "idle_area": "idle: blocked by a task area",
    "waiting_crane": "waiting for the crane",
    "disrupted": "idle: kept from work by a disruption",
    "no_target": "idle: no task open for its type",
    "gone": "gone (no work left, leaving the plane)",
}
PHASES = ("ramp_up", "middle", "tail")
RAMP_UP, TAIL = 0.10, 0.90  # shares of the tasks ended that close the ramp-up, open the tail


def phase_bounds(finish_times: Sequence[float], tasks_total: int,
                 end_s: float) -> list[tuple[float, float]]:
    """The phases' (start, end) in seconds: ramp-up until the ceil(10 %)-th task ended, tail
    from the ceil(90 %)-th on (a phase may be empty; an unfinished floor's tail runs to
    ``end_s``)."""
    import math

    ended = sorted(finish_times)

    def when(share: float) -> float:
        k = max(1, math.ceil(share * tasks_total))
        return ended[k - 1] if k <= len(ended) else end_s

    t1, t2 = when(RAMP_UP), when(TAIL)
    return [(0.0, t1), (t1, t2), (t2, end_s)]


def time_use(events: Sequence[Event], crew_types: dict[str, str], tasks_total: int,
             end_s: float) -> dict[str, dict[str, dict[str, float]]]:
    """Crew-seconds by crew type, phase and category (``CATEGORIES``), summed over the crews of
    each type, up to ``end_s`` (the floor's makespan, or where it stopped).

    Args:
        events: the episode's event log (``engine.log.events`` or a run's events.csv).
        crew_types: crew id -> crew type.
        tasks_total: the case's number of tasks (the phases' shares).
        end_s: where the accounting stops (s).
    """
    bounds = phase_bounds([e.time_s for e in events if e.kind == "task_finish"], tasks_total,
                          end_s)
    out = {ct: {p: dict.fromkeys(CATEGORIES, 0.0) for p in PHASES}
           for ct in sorted(set(crew_types.values()))}
    current: dict[str, tuple[float, str]] = {}

    def close(crew: str, until: float) -> None:
        since, act = current[crew]
        category = CATEGORY_OF.get(act)
        if category is None:
            return
        for phase, (a, b) in zip(PHASES, bounds, strict=True):
            overlap = min(until, b) - max(since, a)
            if overlap > 0:
                out[crew_types[crew]][phase][category] += overlap

    for e in events:
        if e.kind != "activity" or e.crew not in crew_types or e.time_s > end_s:
            continue
        if e.crew in current:
            close(e.crew, e.time_s)
        current[e.crew] = (e.time_s, e.subject)
    for crew in current:
        close(crew, end_s)
    return out


def shares(use: dict[str, dict[str, float]]) -> dict[str, float]:
    """One phase's (or a total's) crew-seconds by category as shares of their sum."""
    total = sum(use.values())
    return {c: (v / total if total > 0 else 0.0) for c, v in use.items()}


def totals(use: dict[str, dict[str, dict[str, float]]]) -> dict[str, dict[str, float]]:
    """Crew-seconds by crew type and category over the whole floor (the phases summed)."""
    return {ct: {c: sum(phases[p][c] for p in PHASES) for c in CATEGORIES}
            for ct, phases in use.items()}
