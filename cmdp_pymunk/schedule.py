"""The schedule an event log records: each task's worked segments and pauses, the schedule
table a planner takes into other tools (``schedule.csv``), and tasks ended over time.

Pure functions of the log (``events.Event``); the charts (``media.charts``) and
``cmdp-simulate`` draw and write from them. Times are simulated seconds.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from itertools import pairwise
from typing import NamedTuple

import numpy as np

from .events import Event

SCHEDULE_FIELDS = ("task", "crew", "start_s", "end_s", "pauses", "paused_s", "finished")


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


def schedule_csv(events: Sequence[Event]) -> str:
    """The schedule as CSV, one row per started task in order of start (``schedule.csv``).

    Columns: ``task``, ``crew`` (the crew that started it), ``start_s``, ``end_s`` (its finish;
    empty when the log ends before it), ``pauses`` (how many times it was paused),
    ``paused_s`` (seconds between its pauses and resumes, a pause still open at the log's end
    counted up to that end), ``finished`` (true or false). Times in simulated seconds.
    """
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(SCHEDULE_FIELDS)
    for bar in task_bars(events):
        paused_s = sum(b - a for a, b in bar.pauses)
        writer.writerow((bar.task, bar.crew, f"{bar.start_s:g}",
                         f"{bar.end_s:g}" if bar.finished else "", len(bar.pauses),
                         f"{paused_s:g}", "true" if bar.finished else "false"))
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
