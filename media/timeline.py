"""The event log of a run read into what its charts draw (section 5.2): no plotting here.

A reader of the log needs no plotting library, so what turns ``events`` into intervals,
counts and paths lives apart from the figures that draw them (``media.gantt``,
``media.layout_views``): a report, a test or a script can ask what a crew did when without
importing matplotlib.

- :class:`RunEnd` and :func:`run_end`: how a run ended (finished at its makespan, stalled, at
  its time limit, or unfinished when only the log and the case are known).
- :func:`activity_intervals`: per crew, what it did when (Fig. 9's categories), from the
  ``activity`` events.
- :func:`disruption_intervals`: every crane breakdown, late delivery, absence and weather stop
  (docs/disruptions.md), from its ``disruption_start`` to its ``disruption_end``.
- :func:`crews_busy`, :func:`crane_lifts`, :func:`crane_per_bin`: the resources over time
  (the resource profile).
- :func:`crew_paths`: per crew, its ``position`` events as (time, x, y) rows (Fig. 11);
  :func:`execution_order`: the components a crew started tasks on, in order.
- :func:`task_components`, :func:`task_types`, :func:`unknown_tasks`: the case's tasks as the
  log names them.

Times in the log are simulated seconds (``HOUR_S`` turns them into the charts' hours);
coordinates are the case's: metres, the plane's origin at its centre, y up.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import NamedTuple

import numpy as np

from cmdp_pymunk.cases.load import Case
from cmdp_pymunk.events import Event, position
from cmdp_pymunk.schedule import log_end_s, makespan_s

HOUR_S = 3600.0
# A crew is busy (the resource profile) while it works on its task: tasking, fetching its
# material, or waiting for the crane; walking and idle are not busy.
BUSY_ACTIVITIES = ("tasking", "fetching", "waiting")
LEFT = "left"


class RunEnd(NamedTuple):
    """How a run ended, as its charts say it.

    ``kind``: ``finished``, ``stalled`` (no task moved on for ``--stall-s``), ``time limit``,
    or ``unfinished`` (a log without its ``summary.json``: why it stopped is not known).
    ``time_s``: the makespan when finished, else when the run stopped. ``ended`` of ``total``
    tasks had ended by then.
    """

    kind: str
    time_s: float
    ended: int
    total: int

    @property
    def finished(self) -> bool:
        return self.kind == FINISHED

    def label(self) -> str:
        """``makespan 0.69 h (2473 s)``, or ``stalled at t = 0.61 h (2191 s), 2 of 3 tasks
        ended``."""
        when = f"{self.time_s / HOUR_S:.2f} h ({self.time_s:.0f} s)"
        if self.finished:
            return f"makespan {when}"
        return f"{self.kind} at t = {when}, {self.ended} of {self.total} tasks ended"


FINISHED = "finished"


def run_end(events: Sequence[Event], total: int, summary: dict | None = None) -> RunEnd:
    """How the run of ``events`` ended, for a case of ``total`` tasks.

    With ``summary`` (``cmdp-simulate``'s ``summary.json``): finished when ``all_finished``,
    else ``stalled`` when it holds a stall report, else ``time limit``, stopped at
    ``simulated_s``. Without it (or without those keys), from the log alone: finished when
    ``total`` distinct tasks have a ``task_finish``, else ``unfinished`` at the log's last
    event. A finished run's time is its makespan (the last ``task_finish``).
    """
    ended = len({e.subject for e in events if e.kind == "task_finish"})
    if summary is not None and "all_finished" in summary:
        done = bool(summary["all_finished"])
        kind = FINISHED if done else "stalled" if summary.get("stalled") else "time limit"
    else:
        done = ended >= total
        kind = FINISHED if done else "unfinished"
    if done:
        return RunEnd(kind, makespan_s(events) or 0.0, ended, total)
    stop = (summary or {}).get("simulated_s")
    return RunEnd(kind, max(log_end_s(events), stop or 0.0), ended, total)


class ActivityInterval(NamedTuple):
    """A crew doing one thing (a Fig. 9 category) from ``start_s`` to ``end_s``."""

    start_s: float
    end_s: float
    category: str


def activity_intervals(events: Sequence[Event],
                       end_s: float | None = None) -> dict[str, list[ActivityInterval]]:
    """Per crew, in the order crews first appear in ``activity`` events, what it did when.

    Each ``activity`` event opens an interval that the crew's next one closes; ``left`` closes
    the last one and opens none. A crew still present at the end of the log has its last
    interval closed at ``end_s`` (default: the log's last event). Zero-length intervals are
    dropped.
    """
    end = log_end_s(events) if end_s is None else end_s
    open_: dict[str, tuple[float, str] | None] = {}
    out: dict[str, list[ActivityInterval]] = {}
    for e in events:
        if e.kind != "activity":
            continue
        out.setdefault(e.crew, [])
        current = open_.get(e.crew)
        if current is not None and e.time_s > current[0]:
            out[e.crew].append(ActivityInterval(current[0], e.time_s, current[1]))
        open_[e.crew] = None if e.subject == LEFT else (e.time_s, e.subject)
    for crew, current in open_.items():
        if current is not None and end > current[0]:
            out[crew].append(ActivityInterval(current[0], end, current[1]))
    return out


class Disruption(NamedTuple):
    """A disruption from ``start_s`` to ``end_s``: its kind (``crane_breakdown``,
    ``late_delivery``, ``absence``, ``weather``) and what it struck (``crane``, a storage, a
    crew, ``plane``)."""

    start_s: float
    end_s: float
    kind: str
    subject: str


def disruption_intervals(events: Sequence[Event], end_s: float | None = None) -> list[Disruption]:
    """Every disruption of the log, from its ``disruption_start`` to its ``disruption_end``
    (one still under way at the log's end closes at ``end_s``, default the log's last event),
    in order of start."""
    end = log_end_s(events) if end_s is None else end_s
    open_: dict[tuple[str, str], float] = {}
    out = []
    for e in events:
        key = (e.detail, e.subject)
        if e.kind == "disruption_start":
            open_.setdefault(key, e.time_s)
        elif e.kind == "disruption_end" and key in open_:
            out.append(Disruption(open_.pop(key), e.time_s, *key))
    out += [Disruption(a, max(a, end), *key) for key, a in open_.items()]
    return sorted(out)


class BusyProfile(NamedTuple):
    """Crews busy per crew type over time, a step function: ``counts[t][j]`` crews of type
    ``t`` are busy from ``times_s[j]`` until ``times_s[j + 1]`` (the last value until the end);
    ``crews[t]`` is how many crews the type has."""

    times_s: np.ndarray
    counts: dict[str, np.ndarray]
    crews: dict[str, int]


def crews_busy(events: Sequence[Event], crew_types: dict[str, str],
               end_s: float | None = None) -> BusyProfile:
    """How many crews of each type are busy (``BUSY_ACTIVITIES``: tasking, fetching material,
    waiting for the crane) at every moment, counted from the ``activity`` intervals
    (:func:`activity_intervals`, closed at ``end_s``): each busy interval adds one from its
    start to its end. Types in ``crew_types``' order of first appearance; a crew not in
    ``crew_types`` counts under its own id."""
    intervals = activity_intervals(events, end_s)
    types = list(dict.fromkeys(crew_types.values()))
    change: dict[float, dict[str, int]] = {0.0: {}}
    for crew, spans in intervals.items():
        kind = crew_types.get(crew, crew)
        if kind not in types:
            types.append(kind)
        for iv in spans:
            if iv.category in BUSY_ACTIVITIES:
                for t, step in ((iv.start_s, 1), (iv.end_s, -1)):
                    at = change.setdefault(t, {})
                    at[kind] = at.get(kind, 0) + step
    times = sorted(change)
    counts = {k: np.cumsum([change[t].get(k, 0) for t in times]).astype(int) for k in types}
    crews = {k: sum(1 for v in crew_types.values() if v == k) or 1 for k in types}
    return BusyProfile(np.asarray(times, dtype=float), counts, crews)


def crane_lifts(events: Sequence[Event]) -> list[tuple[float, str]]:
    """Every crane lift of the log as (its landing, ``crane_done``'s time in s; its kind:
    ``material`` to a storage or ``task``, hoisting assistance), in log order."""
    return [(e.time_s, e.detail) for e in events if e.kind == "crane_done"]


def crane_per_bin(lifts: Sequence[tuple[float, str]], lift_s: dict[str, float], end_s: float,
                  bin_s: float = HOUR_S) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """The crane's lifts and busy time per bin of ``bin_s`` seconds from 0 to ``end_s``.

    A lift lands at its ``crane_done`` and took its kind's own time before it (``lift_s``:
    the case's ``lift_time_s`` for ``material``, ``assist_time_s`` for ``task``; a lift that a
    breakdown held up counts its own time only). Returns the bins' starts (s), per kind the
    lifts landing in each bin (a landing exactly at a bin's edge counts in the later bin) and
    each bin's busy share (0-1 of the bin's length)."""
    n = max(1, int(np.ceil(end_s / bin_s)))
    starts = np.arange(n) * bin_s
    count = {kind: np.zeros(n, dtype=int) for kind in lift_s}
    busy = np.zeros(n)
    for landed, kind in lifts:
        count.setdefault(kind, np.zeros(n, dtype=int))[min(int(landed // bin_s), n - 1)] += 1
        began = max(0.0, landed - lift_s.get(kind, 0.0))
        busy += np.clip(np.minimum(landed, starts + bin_s) - np.maximum(began, starts), 0, None)
    return starts, count, busy / bin_s


def crew_paths(events: Sequence[Event]) -> dict[str, np.ndarray]:
    """Per crew, its ``position`` events as an array of rows ``(time_s, x_m, y_m)``."""
    rows: dict[str, list[tuple[float, float, float]]] = {}
    for e in events:
        if e.kind == "position":
            x, y, _ = position(e)
            rows.setdefault(e.crew, []).append((e.time_s, x, y))
    return {crew: np.asarray(r, dtype=float) for crew, r in rows.items()}


def task_components(case: Case) -> dict[str, str]:
    """Task id -> the id of the component it is performed on."""
    return {t.id: t.component for t in case.tasks}


def task_types(case: Case | None, tasks: Iterable[str]) -> dict[str, str]:
    """Task id -> task type: from the case when given, else the id's prefix before '-'."""
    known = {t.id: t.type for t in case.tasks} if case is not None else {}
    return {t: known.get(t, t.split("-", 1)[0]) for t in tasks}


def execution_order(events: Sequence[Event], case: Case, crew: str) -> list[str]:
    """The components on which ``crew`` started tasks, in the order it first started them."""
    component_of = task_components(case)
    order: list[str] = []
    for e in events:
        if e.kind == "task_start" and e.crew == crew:
            component = component_of.get(e.subject)
            if component is not None and component not in order:
                order.append(component)
    return order


def unknown_tasks(events: Sequence[Event], case: Case) -> list[str]:
    """Task ids in the log's task events that the case does not define (log order)."""
    known = task_components(case)
    seen: list[str] = []
    for e in events:
        if e.kind.startswith("task_") and e.subject not in known and e.subject not in seen:
            seen.append(e.subject)
    return seen
