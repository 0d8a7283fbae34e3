"""The schedule an event log records: each task's worked segments and pauses, the schedule
table a planner takes into other tools (``schedule.csv``), and tasks ended over time.

Pure functions of the log (``events.Event``; ``schedule.csv`` also reads the case, for the tasks
that never started); the charts (``media.charts``) and ``cmdp-simulate`` draw and write from
them. Times are simulated seconds.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from itertools import pairwise
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from .events import Event
from .precedence import Pool

if TYPE_CHECKING:
    from .cases.load import Case

# The first seven columns are those of schedule.csv before it listed every task (readers that
# take them by position keep working); the four after them came with it.
SCHEDULE_FIELDS = ("task", "crew", "start_s", "end_s", "pauses", "paused_s", "finished",
                   "task_type", "component", "status", "duration_s")
# With a working calendar (the case's ``calendar``), after all of those: the dates of
# ``start_s`` and ``end_s`` (``workcalendar``), ISO 8601 to the second.
CALENDAR_FIELDS = ("start", "end")


class TaskBar(NamedTuple):
    """One task's bar in Fig. 10: the intervals it was being worked on, pauses between them.

    ``finished`` is False when the log ends before the task's ``task_finish``; its last segment
    then ends at the log's end.
    """

    task: str
    crew: str
    segments: tuple[tuple[float, float], ...]
    finished: bool

    @property
    def start_s(self) -> float:
        return self.segments[0][0]

    @property
    def end_s(self) -> float:
        return self.segments[-1][1]

    @property
    def pauses(self) -> tuple[tuple[float, float], ...]:
        return tuple((a[1], b[0]) for a, b in pairwise(self.segments))


def log_end_s(events: Sequence[Event]) -> float:
    """The time of the log's last event (0 for an empty log)."""
    return max((e.time_s for e in events), default=0.0)


def makespan_s(events: Sequence[Event]) -> float | None:
    """The time of the last ``task_finish``, or None when no task finished."""
    return max((e.time_s for e in events if e.kind == "task_finish"), default=None)


def finish_times(events: Sequence[Event]) -> list[float]:
    """The times of every ``task_finish``, in increasing order."""
    return sorted(e.time_s for e in events if e.kind == "task_finish")


def task_bars(events: Sequence[Event], end_s: float | None = None) -> list[TaskBar]:
    """Every started task's worked segments, sorted by start time (ties: log order).

    ``task_start`` and ``task_resume`` open a segment; ``task_pause`` and ``task_finish`` close
    it. A task unfinished when the log ends has its open segment closed at ``end_s`` (default:
    the log's last event).
    """
    end = log_end_s(events) if end_s is None else end_s
    crews: dict[str, str] = {}
    segments: dict[str, list[tuple[float, float]]] = {}
    open_since: dict[str, float | None] = {}
    finished: set[str] = set()
    for e in events:
        if e.kind in ("task_start", "task_resume"):
            crews.setdefault(e.subject, e.crew)
            segments.setdefault(e.subject, [])
            if open_since.get(e.subject) is None:
                open_since[e.subject] = e.time_s
        elif e.kind in ("task_pause", "task_finish") and e.subject in segments:
            since = open_since.get(e.subject)
            if since is not None:
                segments[e.subject].append((since, e.time_s))
                open_since[e.subject] = None
            if e.kind == "task_finish":
                finished.add(e.subject)
    for task, since in open_since.items():
        if since is not None:
            segments[task].append((since, max(end, since)))
    bars = [TaskBar(t, crews[t], tuple(s), t in finished) for t, s in segments.items() if s]
    return sorted(bars, key=lambda b: b.start_s)  # stable: ties keep the log's order


def task_pools(events: Sequence[Event], case: Case) -> dict[str, Pool]:
    """Each task of the case -> its pool when the log ends (section 3.5), in the case's order.

    ``end`` once it has a ``task_finish``, ``on`` once it has a ``task_start`` (paused or not),
    else ``queue`` when every predecessor has ended, else ``wait``: the flow of
    ``precedence`` replayed from the log.
    """
    started = {e.subject for e in events if e.kind == "task_start"}
    ended = {e.subject for e in events if e.kind == "task_finish"}
    pools = {}
    for t in case.tasks:
        if t.id in ended:
            pools[t.id] = Pool.END
        elif t.id in started:
            pools[t.id] = Pool.ON
        else:
            pools[t.id] = Pool.QUEUE if all(p in ended for p in t.predecessors) else Pool.WAIT
    return pools


def paused_at_end(events: Sequence[Event]) -> dict[str, float]:
    """Task -> the time of its last ``task_pause``, for the tasks still paused when the log
    ends (their last task event is that pause)."""
    last: dict[str, Event] = {}
    for e in events:
        if e.kind in ("task_start", "task_pause", "task_resume", "task_finish"):
            last[e.subject] = e
    return {t: e.time_s for t, e in last.items() if e.kind == "task_pause"}


def schedule_csv(events: Sequence[Event], case: Case, end_s: float | None = None) -> str:
    """The schedule as CSV, one row per task of ``case`` (``schedule.csv``): the tasks that
    started in order of start (ties: log order), then those that never did in the case's order.

    Columns: ``task``, ``crew`` (the crew that started it; empty if none did), ``start_s``,
    ``end_s`` (its finish; empty when it did not finish), ``pauses`` (how many times it was
    paused), ``paused_s`` (seconds between its pauses and resumes, a pause still open when the
    run stopped counted up to that stop), ``finished`` (true or false), ``task_type``,
    ``component``, ``status`` (its pool when the run stopped, section 3.5: ``end``, ``on``
    (started, not finished, paused or not), ``queue`` (not started, its predecessors all
    ended), ``wait`` (not started, a predecessor not ended)), ``duration_s`` (``end_s`` minus
    ``start_s``, pauses included; empty when it did not finish). Times in simulated seconds;
    a task that never started has its times empty and 0 pauses. When the case has a working
    calendar, two more columns: ``start`` and ``end``, the dates of ``start_s`` and ``end_s``
    (``workcalendar.calendar_datetime``, ISO 8601 to the second, e.g. 2026-01-12T08:00:01;
    empty where those are).

    Args:
        events: the run's event log.
        case: the case the run was made with (its tasks, types, components, predecessors).
        end_s: when the run stopped (``summary.json``'s ``simulated_s``), which may come after
            the log's last event; default the log's last event.
    """
    end = log_end_s(events) if end_s is None else max(end_s, log_end_s(events))
    pools = task_pools(events, case)
    spec = {t.id: t for t in case.tasks}
    paused_since = paused_at_end(events)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    calendar = getattr(case, "calendar", None)

    def dates(start_s: float | None, end_s: float | None) -> tuple[str, ...]:
        if calendar is None:
            return ()
        from .workcalendar import calendar_datetime, iso

        return tuple("" if t is None else iso(calendar_datetime(calendar, t))
                     for t in (start_s, end_s))

    writer.writerow(SCHEDULE_FIELDS + (CALENDAR_FIELDS if calendar is not None else ()))
    bars = task_bars(events, end)
    for bar in bars:
        paused_s = sum(b - a for a, b in bar.pauses)
        pauses = len(bar.pauses)
        if not bar.finished and bar.task in paused_since:  # paused when the run stopped
            paused_s += end - paused_since[bar.task]
            pauses += 1
        task = spec.get(bar.task)
        status = pools[bar.task].name.lower() if task is not None else \
            (Pool.END if bar.finished else Pool.ON).name.lower()
        writer.writerow((bar.task, bar.crew, f"{bar.start_s:g}",
                         f"{bar.end_s:g}" if bar.finished else "", pauses,
                         f"{paused_s:g}", "true" if bar.finished else "false",
                         task.type if task else "", task.component if task else "", status,
                         f"{bar.end_s - bar.start_s:g}" if bar.finished else "")
                        + dates(bar.start_s, bar.end_s if bar.finished else None))
    started = {b.task for b in bars}
    for task in case.tasks:
        if task.id not in started:
            writer.writerow((task.id, "", "", "", 0, "0", "false", task.type, task.component,
                             pools[task.id].name.lower(), "") + dates(None, None))
    return buf.getvalue()


def tasks_ended(finishes: Sequence[Sequence[float]], times_s: np.ndarray) -> np.ndarray:
    """Tasks ended by each time, per episode: an S-curve per row.

    Args:
        finishes: per episode, its ``finish_times`` (increasing, simulated seconds).
        times_s: the times at which to count, shape (T,).

    Returns:
        int array (episodes, T): entry (k, j) counts episode k's finishes at or before
        ``times_s[j]``.
    """
    times_s = np.asarray(times_s, dtype=float)
    return np.array([np.searchsorted(np.asarray(f, dtype=float), times_s, side="right")
                     for f in finishes], dtype=int).reshape(len(finishes), len(times_s))
