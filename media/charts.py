"""Charts of a run, drawn from its event log (section 5.2, Figs. 9, 10 and 11).

- :func:`gantt_agents`, Fig. 9: one row per crew, a bar per ``activity`` interval: idle grey
  (a lighter grey per cause: predecessor, task area, no target), navigating and deregistered
  (walking to the outlet) yellow, tasking red, fetching and waiting for the crane green.
- :func:`gantt_tasks`, Fig. 10: one bar per task from its start to its finish, pauses drawn as
  lighter segments, tasks sorted by start time from the top and labelled with their ids,
  coloured by task type.
- :func:`trajectories`, Fig. 11: (a) one crew's path (the hoisting crew HIC by default), wider
  as time goes on, with the components it worked on numbered in the order it started them;
  (b) every crew's path, one small panel per crew.
- :func:`stall_picture`: the floor where a run stalled (``report.stall_report``): every crew
  where it stands, drawn to its size, a walking crew's target and the way it means to walk,
  and its last minutes of path from the log.
- :func:`resource_profile`: the resources over time, counted from the log: crews busy per
  crew type (tasking, fetching material, waiting for the crane; :func:`crews_busy`), stacked,
  and the crane's lifts landed per hour (per 15 minutes in a run under 4 h) with its busy
  share (:func:`crane_per_bin`).
- :func:`draw_run` draws all four into a run folder; :class:`GifStream` writes frames as a GIF
  as they come (:func:`write_gif` for a sequence of them). A run on the event floor
  (``summary.json``'s ``fidelity``, docs/event-floor.md) says so in the Gantt charts' titles
  and gets no trajectories: its crews are where the floor has them at events only, not along
  their walks.

Both Gantt charts mark how the run ended (:class:`RunEnd`): a finished run's makespan (the
last ``task_finish``) as a dashed line, or, for a run that stalled or reached its time limit,
a dotted red line where it stopped, labelled and added to the title as "stalled at t = 0.61 h
(2191 s), 2 of 3 tasks ended" ("time limit at ...", or "unfinished at ..." when only the log
and the case are known). :func:`draw_run` learns it from the run folder's ``summary.json``
(``all_finished``, ``stalled``, ``simulated_s``) and the case's number of tasks.

With disruptions (docs/disruptions.md), both Gantt charts shade a band across the chart for
every crane breakdown, late delivery and weather stop (``disruption_intervals``), and a crew
kept from working shows the disruption's own idle colour in Fig. 9 (an absence hatched).

Times in the log are simulated seconds; the charts' time axes are in hours. Coordinates are the
case's: metres, the plane's origin at its centre, y up.

With a working calendar (the case's ``calendar``; ``cmdp_pymunk.workcalendar``) both Gantt
charts keep their axis of simulated (working) hours and get a date axis on top (``date_ticks``):
second 0 with its date and time, then each working day's opening, labelled with its date; the
axis label names the start and the working time, and the makespan's legend entry (or where an
unfinished run stopped) its date.

Figures are made with ``matplotlib.figure.Figure`` and rendered by its own Agg canvas, never
through ``pyplot``: no global backend is switched and no figure is registered anywhere, so
nothing needs closing and nothing leaks. Every file is rendered into memory first and then
written atomically (``cmdp_pymunk.events.write_atomic``).

Command line: ``python -m media.charts RUN_DIR [--case PATH]`` redraws a saved run's charts;
without ``--case`` it uses the ``case.json`` that ``cmdp-simulate`` saves with a run (in RUN_DIR
or its parent), else the built-in case.
"""

from __future__ import annotations

import argparse
import io
import json
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np
from matplotlib.collections import LineCollection, PatchCollection, PolyCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch, Rectangle

from cmdp_pymunk.cases.load import Calendar, Case
from cmdp_pymunk.events import Event, position, read_csv, write_atomic
from cmdp_pymunk.schedule import log_end_s, makespan_s, paused_at_end, task_bars
from cmdp_pymunk.workcalendar import (
    calendar_datetime,
    describe,
    first_working_moment,
    working_day_openings,
)

HOUR_S = 3600.0
DPI = 110
MAX_DATE_TICKS = 12  # beyond this many working days the date axis labels every k-th
TASK_ROW_IN = 0.16  # Fig. 10's row height (inches): room for a task id in 7-point type
MAX_FIGURE_IN = 40.0  # beyond this height rows get thinner and the ids smaller

# Fig. 9's colours: idle grey, navigating yellow, tasking red, materials or crane green.
ACTIVITY_STYLE: dict[str, dict] = {
    "idle_predecessor": {"color": "#7f7f7f", "label": "idle: waiting for predecessors"},
    "idle_area": {"color": "#a8a8a8", "label": "idle: blocked by task areas"},
    "idle_no_target": {"color": "#d0d0d0", "label": "idle: no target"},
    "navigating": {"color": "#f2c200", "label": "navigating"},
    "deregistered": {"color": "#f2c200", "hatch": "////", "edge": "#8a6d00",
                     "label": "leaving (no work left)"},
    "tasking": {"color": "#d62728", "label": "tasking"},
    "fetching": {"color": "#2ca02c", "label": "fetching materials"},
    "waiting": {"color": "#98df8a", "label": "waiting for the crane"},
    # kept from working by a disruption (beyond the paper; docs/disruptions.md)
    "idle_crane_breakdown": {"color": "#9467bd", "label": "idle: crane broken down"},
    "idle_late_delivery": {"color": "#c5b0d5", "label": "idle: delivery late"},
    "idle_absence": {"color": "#ffffff", "hatch": "xxxx", "edge": "#555555",
                     "label": "absent (off the plane)"},
    "idle_weather": {"color": "#17becf", "label": "idle: weather stop"},
}
# Disruption bands behind both Gantt charts: what was disrupted when (``disruption_*`` events).
# An absence shows in its crew's row (``idle_absence``) and draws no band.
BAND_STYLE: dict[str, dict] = {
    "crane_breakdown": {"color": "#9467bd", "label": "crane broken down"},
    "late_delivery": {"color": "#e7969c", "label": "delivery late"},
    "weather": {"color": "#17becf", "label": "weather stop"},
}
OTHER_ACTIVITY = {"color": "#1f77b4", "label": "other"}  # a category this module does not know
# A crew is busy (the resource profile) while it works on its task: tasking, fetching its
# material, or waiting for the crane; walking and idle are not busy.
BUSY_ACTIVITIES = ("tasking", "fetching", "waiting")
LIFT_STYLE = {"material": {"color": "#2ca02c", "label": "material lifts"},
              "task": {"color": "#98df8a", "label": "hoisting assists"}}
LEFT = "left"

PRECAST_FILL = "#f5d742"
PATH_COLOUR = "#d95f02"  # panel (a): orange reads on both the yellow and the grey components


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


def read_summary(run_dir: Path) -> dict | None:
    """``run_dir/summary.json`` as a dict; None when it is absent or unreadable (the charts
    then judge the run from its log and case alone)."""
    try:
        data = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    return data if isinstance(data, dict) else None


class ActivityInterval(NamedTuple):
    """A crew doing one thing (a Fig. 9 category) from ``start_s`` to ``end_s``."""

    start_s: float
    end_s: float
    category: str


# ------------------------------------------------------------------------------------------
# Pure helpers: the event log turned into intervals, bars and paths.


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


def _draw_bands(ax, events: Sequence[Event]) -> list:
    """Shade every crane breakdown, late delivery and weather stop across the chart; returns
    a legend handle per kind drawn."""
    drawn: list[str] = []
    for d in disruption_intervals(events):
        style = BAND_STYLE.get(d.kind)
        if style is None:
            continue
        ax.axvspan(d.start_s / HOUR_S, d.end_s / HOUR_S, color=style["color"], alpha=0.18,
                   linewidth=0, zorder=0)
        if d.kind not in drawn:
            drawn.append(d.kind)
    return [Patch(facecolor=BAND_STYLE[k]["color"], alpha=0.18,
                  label=f"band: {BAND_STYLE[k]['label']}") for k in drawn]


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


def default_crew(case: Case) -> str:
    """Fig. 11's crew: the first hoisting crew (type HIC) if the case has one, else its first."""
    return next((c.id for c in case.crews if c.type == "HIC"), case.crews[0].id)


def widths_by_time(times: np.ndarray, narrow: float = 0.6, wide: float = 4.0) -> np.ndarray:
    """Line widths for the segments between consecutive ``times``: narrow early, wide late."""
    if len(times) < 2:
        return np.zeros(0)
    mid = (times[:-1] + times[1:]) / 2.0
    span = times[-1] - times[0]
    frac = (mid - times[0]) / span if span > 0 else np.zeros_like(mid)
    return narrow + (wide - narrow) * frac


def unknown_tasks(events: Sequence[Event], case: Case) -> list[str]:
    """Task ids in the log's task events that the case does not define (log order)."""
    known = task_components(case)
    seen: list[str] = []
    for e in events:
        if e.kind.startswith("task_") and e.subject not in known and e.subject not in seen:
            seen.append(e.subject)
    return seen


# ------------------------------------------------------------------------------------------
# Figures.


def save_png(fig: Figure, path: str | Path) -> Path:
    """Render the figure to PNG in memory, then write it atomically."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    path = Path(path)
    write_atomic(path, buf.getvalue())
    return path


def _mark_end(ax, events: Sequence[Event], end: RunEnd | None,
              calendar: Calendar | None = None) -> Line2D | None:
    """A finished run's makespan, dashed black; an unfinished run's stop, dotted red. Without
    ``end`` the last ``task_finish`` is drawn as the makespan (the log alone cannot tell).
    With a calendar the label ends with the date: ``makespan 9.43 h (33943 s), Tue
    2026-01-06 09:25``."""
    if end is None:
        span = makespan_s(events)
        if span is None:
            return None
        end = RunEnd(FINISHED, span, 0, 0)
    label = end.label()
    if calendar is not None:
        label += f", {calendar_datetime(calendar, end.time_s):%a %Y-%m-%d %H:%M}"
    if end.finished:
        return ax.axvline(end.time_s / HOUR_S, color="black", linestyle="--", linewidth=1.2,
                          label=label)
    return ax.axvline(end.time_s / HOUR_S, color="#b2182b", linestyle=":", linewidth=1.6,
                      label=label)


def date_ticks(calendar: Calendar, end_s: float) -> list[tuple[float, str]]:
    """The date axis's ticks, as (simulated hours, label): second 0 with its date and time
    (``Fri 09 Jan 15:00``), then the opening of each working day by ``end_s`` (``Mon 12 Jan``),
    every k-th of them when there are more than ``MAX_DATE_TICKS``."""
    zero = first_working_moment(calendar)
    openings = working_day_openings(calendar, end_s)
    step = -(-len(openings) // (MAX_DATE_TICKS - 1)) if openings else 1
    ticks = [(0.0, f"{zero:%a %d %b %H:%M}")]
    ticks += [(t / HOUR_S, f"{day:%a %d %b}") for t, day in openings[step - 1::step]]
    return ticks


def _date_axis(ax, calendar: Calendar | None, end_s: float) -> None:
    """The date axis on top of a Gantt chart whose x axis is in simulated hours."""
    if calendar is None:
        return
    ax.set_xlabel("simulated working time (h)")
    top = ax.secondary_xaxis("top")
    ticks = date_ticks(calendar, end_s)
    top.set_xticks([t for t, _ in ticks], [label for _, label in ticks], fontsize=8)
    zero = first_working_moment(calendar)
    top.set_xlabel(f"date (second 0: {zero:%a %Y-%m-%d %H:%M}; working {describe(calendar)})",
                   fontsize=8)


def _chart_end_s(events: Sequence[Event], end: RunEnd | None) -> float | None:
    """Where bars still open close: an unfinished run's stop (it may come after the log's last
    event), else the log's last event (None)."""
    return None if end is None or end.finished else max(end.time_s, log_end_s(events))


def _titled(title: str, end: RunEnd | None) -> str:
    """The title, with how an unfinished run stopped on a second line."""
    return title if end is None or end.finished else f"{title}\n{end.label()}"


def gantt_agents(events: Sequence[Event], path: str | Path, title: str | None = None,
                 end: RunEnd | None = None, calendar: Calendar | None = None) -> Path:
    """Fig. 9, the agents' Gantt chart (:func:`gantt_agents_figure`), written as a PNG to
    ``path``; returns the path."""
    return save_png(gantt_agents_figure(events, title, end, calendar), path)


def gantt_agents_figure(events: Sequence[Event], title: str | None = None,
                        end: RunEnd | None = None, calendar: Calendar | None = None) -> Figure:
    """Fig. 9, the agents' Gantt chart: one row per crew, a bar per activity interval.

    Rows in the order crews first appear in ``activity`` events, the first on top. Nothing is
    drawn after a crew's ``left``. ``end`` (:func:`run_end`) marks how the run ended: the
    makespan as a dashed line, or where an unfinished run stopped as a dotted red line, said
    in the title too; without it the dashed line is the last ``task_finish``. ``calendar``:
    a date axis on top (:func:`date_ticks`).
    """
    stop = _chart_end_s(events, end)
    intervals = activity_intervals(events, stop)
    crews = list(intervals)
    fig = Figure(figsize=(11, 1.6 + 0.45 * max(len(crews), 1)), layout="constrained")
    ax = fig.add_subplot()
    seen: list[str] = []
    for row, crew in enumerate(crews):
        by_category: dict[str, list[tuple[float, float]]] = {}
        for iv in intervals[crew]:
            by_category.setdefault(iv.category, []).append(
                (iv.start_s / HOUR_S, (iv.end_s - iv.start_s) / HOUR_S))
        for category, spans in by_category.items():
            style = ACTIVITY_STYLE.get(category, OTHER_ACTIVITY)
            ax.broken_barh(spans, (row - 0.38, 0.76), facecolors=style["color"],
                           hatch=style.get("hatch"), edgecolor=style.get("edge", "none"),
                           linewidth=0)
            if category not in seen:
                seen.append(category)
    ax.set_yticks(range(len(crews)), crews)
    ax.set_ylim(len(crews) - 0.5, -0.5)
    ax.set_xlim(0, max(log_end_s(events), stop or 0.0, 1.0) / HOUR_S * 1.01)
    ax.set_xlabel("simulated time (h)")
    _date_axis(ax, calendar, max(log_end_s(events), stop or 0.0))
    ax.set_ylabel("crew")
    ax.grid(axis="x", color="#e5e5e5", linewidth=0.6)
    ax.set_axisbelow(True)
    order = [c for c in ACTIVITY_STYLE if c in seen] + [c for c in seen if c not in ACTIVITY_STYLE]
    bands = _draw_bands(ax, events)
    handles: list = []
    for c in order:
        style = ACTIVITY_STYLE.get(c, {**OTHER_ACTIVITY, "label": c})
        handles.append(Patch(facecolor=style["color"], hatch=style.get("hatch"),
                             edgecolor=style.get("edge", style["color"]), linewidth=0,
                             label=style["label"]))
    handles += bands
    line = _mark_end(ax, events, end, calendar)
    if line is not None:
        handles.append(line)
    if handles:
        fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 5),
                   fontsize=8, frameon=False)
    ax.set_title(_titled(title or "Crews' activities (Fig. 9)", end))
    return fig


def _type_colours(types: Sequence[str]) -> dict[str, str]:
    palette = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
               "#17becf", "#bcbd22", "#7f7f7f"]
    return {t: palette[i % len(palette)] for i, t in enumerate(types)}


def gantt_tasks(events: Sequence[Event], path: str | Path, case: Case | None = None,
                title: str | None = None, end: RunEnd | None = None) -> Path:
    """Fig. 10, the tasks' Gantt chart (:func:`gantt_tasks_figure`), written as a PNG to
    ``path``; returns the path."""
    return save_png(gantt_tasks_figure(events, case, title, end), path)


def gantt_tasks_figure(events: Sequence[Event], case: Case | None = None,
                       title: str | None = None, end: RunEnd | None = None) -> Figure:
    """Fig. 10, the tasks' Gantt chart: a bar per task from its start to its finish.

    Tasks sorted by start time, the first on top, each row labelled with its task id; pauses
    drawn as lighter segments; colours by task type (from ``case`` when given, else the task
    id's prefix before '-'). ``end`` (default: :func:`run_end` of the log and ``case``) marks
    how the run ended: the makespan as a dashed line, or where an unfinished run stopped as a
    dotted red line, said in the title too; without ``end`` and ``case`` the dashed line is
    the last ``task_finish``. A case with a working calendar gets a date axis on top
    (:func:`date_ticks`).
    """
    calendar = case.calendar if case is not None else None
    if end is None and case is not None:
        end = run_end(events, len(case.tasks))
    stop = _chart_end_s(events, end)
    bars = task_bars(events, stop)
    type_of = task_types(case, (b.task for b in bars))
    present = list(dict.fromkeys(type_of[b.task] for b in bars))
    if case is not None:  # the case's order, so colours are the same from run to run
        present = [t for t in case.task_types if t in present] + \
                  [t for t in present if t not in case.task_types]
    colours = _type_colours(present)
    n = len(bars)
    row_in = min(TASK_ROW_IN, (MAX_FIGURE_IN - 2.2) / max(n, 1))
    fig = Figure(figsize=(11, 2.2 + row_in * max(n, 1)), layout="constrained")
    ax = fig.add_subplot()
    # An unfinished run's task still paused when it stopped: its pause runs to the stop.
    still_paused = paused_at_end(events) if stop is not None else {}
    # every bar in two collections (the pauses, faint, under the work), not a pair of
    # ``broken_barh`` per task: an artist a row cost most of the chart's drawing
    drawn: dict[bool, tuple[list, list]] = {True: ([], []), False: ([], [])}  # paused?
    for row, bar in enumerate(bars):
        colour = colours[type_of[bar.task]]
        pauses = bar.pauses
        if bar.task in still_paused and not bar.finished:
            pauses += ((still_paused[bar.task], stop),)
        for paused, spans in ((True, pauses), (False, bar.segments)):
            verts, faces = drawn[paused]
            for a, b in spans:  # x1 as broken_barh made it: the start plus the width
                x0, x1 = a / HOUR_S, a / HOUR_S + (b - a) / HOUR_S
                verts.append([(x0, row - 0.4), (x0, row + 0.4), (x1, row + 0.4), (x1, row - 0.4)])
                faces.append(colour)
    for paused in (True, False):
        verts, faces = drawn[paused]
        if verts:
            ax.add_collection(PolyCollection(verts, facecolors=faces, edgecolors="none",
                                             alpha=0.25 if paused else None), autolim=False)
    ax.set_yticks(range(n), [b.task for b in bars], fontsize=min(7.0, 0.75 * 72 * row_in))
    ax.set_ylim(max(n, 1) - 0.5, -0.5)
    ax.set_xlim(0, max(log_end_s(events), stop or 0.0, 1.0) / HOUR_S * 1.01)
    ax.set_xlabel("simulated time (h)")
    _date_axis(ax, calendar, max(log_end_s(events), stop or 0.0))
    ax.set_ylabel(f"{n} tasks, by start time" if end is None or n >= end.total else
                  f"{n} of {end.total} tasks started, by start time")
    ax.grid(axis="x", color="#e5e5e5", linewidth=0.6)
    ax.set_axisbelow(True)

    def type_label(t: str) -> str:
        if case is not None and t in case.task_types:
            return f"{t}: {case.task_types[t].name}"
        return t

    handles: list = [Patch(facecolor=colours[t], label=type_label(t)) for t in present]
    if still_paused or any(b.pauses for b in bars):
        handles.append(Patch(facecolor="#777777", alpha=0.25, label="paused"))
    handles += _draw_bands(ax, events)
    line = _mark_end(ax, events, end, calendar)
    if line is not None:
        handles.append(line)
    if handles:
        ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)
    ax.set_title(_titled(title or "Tasks (Fig. 10)", end))
    return fig


def resource_profile(events: Sequence[Event], case: Case, path: str | Path,
                     title: str | None = None, end: RunEnd | None = None) -> Path:
    """The resource profile (:func:`resource_profile_figure`), written as a PNG to ``path``;
    returns the path."""
    return save_png(resource_profile_figure(events, case, title, end), path)


def resource_profile_figure(events: Sequence[Event], case: Case, title: str | None = None,
                            end: RunEnd | None = None) -> Figure:
    """The resources over time: (top) crews busy per crew type, stacked (:func:`crews_busy`),
    the number of crews a dotted line; (bottom) the crane's lifts landed per bin, stacked by
    kind, and its busy share of each bin on the right axis (:func:`crane_per_bin`; bins of an
    hour, of 15 minutes for a run under 4 h). ``end`` marks how the run ended, as on the Gantt
    charts (default :func:`run_end` of the log and the case); a case with a working calendar
    gets a date axis on top."""
    if end is None:
        end = run_end(events, len(case.tasks))
    stop = max(log_end_s(events), _chart_end_s(events, end) or 0.0, 1.0)
    crew_types = {c.id: c.type for c in case.crews}
    profile = crews_busy(events, crew_types, _chart_end_s(events, end))
    fig = Figure(figsize=(11, 6.2), layout="constrained")
    ax, ax_crane = fig.subplots(2, 1, sharex=True, height_ratios=(3, 2))
    hours = np.append(profile.times_s, max(stop, profile.times_s[-1])) / HOUR_S
    colours = _type_colours(list(profile.counts))
    base = np.zeros(len(hours))
    for kind, counts in profile.counts.items():
        top = base + np.append(counts, counts[-1])
        name = case.crew_types[kind].name if kind in case.crew_types else kind
        n = profile.crews[kind]
        ax.fill_between(hours, base, top, step="post", color=colours[kind], alpha=0.8,
                        linewidth=0, label=f"{kind}: {name} ({n} crew{'s' if n > 1 else ''})")
        base = top
    total = sum(profile.crews.values())
    ax.axhline(total, color="#444444", linestyle=":", linewidth=1,
               label=f"all {total} crews")
    ax.set_ylim(0, total * 1.08)
    ax.yaxis.get_major_locator().set_params(integer=True)
    ax.set_ylabel("crews busy\n(tasking, fetching,\nwaiting for the crane)", fontsize=8)
    bin_s = HOUR_S if stop >= 4 * HOUR_S else HOUR_S / 4
    starts, lifts, busy = crane_per_bin(
        crane_lifts(events), {"material": case.crane.lift_time_s,
                              "task": case.crane.assist_time_s}, stop, bin_s)
    bottom = np.zeros(len(starts))
    for kind, count in lifts.items():
        style = LIFT_STYLE.get(kind, {"color": "#1f77b4", "label": kind})
        ax_crane.bar(starts / HOUR_S, count, width=bin_s / HOUR_S, bottom=bottom, align="edge",
                     color=style["color"], edgecolor="white", linewidth=0.5,
                     label=style["label"])
        bottom = bottom + count
    ax_crane.set_ylabel(f"crane lifts\nper {bin_s / 60:.0f} min", fontsize=8)
    ax_crane.yaxis.get_major_locator().set_params(integer=True)
    share = ax_crane.twinx()
    share.step(np.append(starts, starts[-1] + bin_s) / HOUR_S, np.append(busy, busy[-1]) * 100,
               where="post", color="#444444", linewidth=1.2, label="crane busy (%)")
    share.set_ylim(0, 105)
    share.set_ylabel("crane busy (% of the bin)", fontsize=8)
    for a in (ax, ax_crane):
        a.grid(axis="x", color="#e5e5e5", linewidth=0.6)
        a.set_axisbelow(True)
    ax.set_xlim(0, stop / HOUR_S * 1.01)
    calendar = case.calendar
    _date_axis(ax, calendar, stop)
    ax.set_xlabel("")
    ax_crane.set_xlabel("simulated working time (h)" if calendar is not None
                        else "simulated time (h)")
    _mark_end(ax, events, end, calendar)
    crane_line = _mark_end(ax_crane, events, end, calendar)
    if crane_line is not None:  # said once, in the upper legend
        crane_line.set_label("_nolegend_")
    ax.legend(loc="upper right", fontsize=7, framealpha=0.9)
    ax_crane.legend(handles=ax_crane.get_legend_handles_labels()[0]
                    + share.get_legend_handles_labels()[0], loc="upper right", fontsize=7,
                    framealpha=0.9)
    ax.set_title(_titled(title or "Resources over time", end))
    return fig


def _draw_layout(ax, case: Case, faint: bool = False) -> None:
    """The plane's outline, storages, components, the outlet and the crane, equal aspect."""
    plane = case.plane
    hw, hh = plane.half_extents
    ax.add_patch(Rectangle((-hw, -hh), plane.width_m, plane.height_m, fill=False,
                           edgecolor="black", linewidth=1.5))
    alpha = 0.5 if faint else 1.0
    # the storages and components as one collection, each patch keeping its own colours: a
    # patch an artist cost most of a chart's drawing (40 components on each of 8 panels)
    patches = []
    for s in case.storages:
        patches.append(Rectangle((s.x_m - s.width_m / 2, s.y_m - s.height_m / 2), s.width_m,
                                 s.height_m, facecolor="#dbe9f6", edgecolor="#4a7bb7",
                                 linewidth=0.8, alpha=alpha))
        ax.text(s.x_m, s.y_m, s.id, ha="center", va="center", fontsize=6, color="#2b4f7e",
                alpha=alpha)
    for c in case.components:
        xy = (c.x_m - c.width_m / 2, c.y_m - c.height_m / 2)
        if c.kind == "precast":
            patch = Rectangle(xy, c.width_m, c.height_m, facecolor=PRECAST_FILL,
                              edgecolor="#8a7000", linewidth=0.8, alpha=alpha)
        else:
            patch = Rectangle(xy, c.width_m, c.height_m, fill=False, edgecolor="#888888",
                              linewidth=0.8, alpha=alpha)
        patches.append(patch)
    ax.add_collection(PatchCollection(patches, match_original=True), autolim=False)
    ax.add_patch(Circle((plane.outlet_x_m, plane.outlet_y_m), plane.outlet_radius_m,
                        facecolor="none", edgecolor="#444444", linestyle=":", linewidth=1.0))
    ax.text(plane.outlet_x_m, plane.outlet_y_m, "outlet", ha="center", va="center",
            fontsize=6, color="#444444")
    ax.plot([case.crane.x_m], [case.crane.y_m], marker="^", color="#444444", markersize=6,
            linestyle="none")
    margin = 0.03 * max(plane.width_m, plane.height_m)
    ax.set_xlim(-hw - margin, hw + margin)
    ax.set_ylim(-hh - margin, hh + margin)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def trajectories(events: Sequence[Event], case: Case, path: str | Path,
                 crew: str | None = None) -> Path:
    """Fig. 11: (a) one crew's path and execution order, (b) every crew's path.

    (a) The path of ``crew`` (default :func:`default_crew`: the hoisting crew) from its
    ``position`` events, narrow early and wide late, over the layout: precast components filled
    yellow, the others outlined grey, storages light blue, the outlet and the crane (triangle).
    The components on which it started tasks carry their order of execution. (b) Small
    multiples, one panel per crew (:func:`crew_multiples`): every crew's path, none hiding
    another's. Writes a PNG to ``path`` and returns it.
    """
    crew_ids = [c.id for c in case.crews]
    crew = default_crew(case) if crew is None else crew
    if crew not in crew_ids:
        raise ValueError(f"crew {crew!r} is not in case {case.case.name!r}; fix: pass one of "
                         f"{', '.join(crew_ids)}")
    paths = crew_paths(events)
    hw, hh = case.plane.half_extents
    fig = Figure(figsize=(14, 6.0 * hh / hw + 1.3), layout="constrained")
    left, right = fig.subfigures(1, 2, wspace=0.02)
    ax_a = left.subplots()

    _draw_layout(ax_a, case)
    own = paths.get(crew)
    if own is not None and len(own) >= 2:
        points = own[:, 1:3]
        segments = np.stack([points[:-1], points[1:]], axis=1)
        ax_a.add_collection(LineCollection(segments, linewidths=widths_by_time(own[:, 0]),
                                           colors=PATH_COLOUR, capstyle="round"))
    if own is not None and len(own):
        ax_a.plot(own[0, 1], own[0, 2], "o", color=PATH_COLOUR, markersize=5)
        ax_a.plot(own[-1, 1], own[-1, 2], "s", color=PATH_COLOUR, markersize=5)
    else:
        ax_a.text(0, 0, f"no position events for {crew}\n(log positions with "
                  "position_log_every_s)", ha="center", va="center", fontsize=9)
    components = {c.id: c for c in case.components}
    for number, cid in enumerate(execution_order(events, case, crew), start=1):
        c = components.get(cid)
        if c is None:
            continue
        ax_a.annotate(str(number), (c.x_m + c.width_m / 2, c.y_m + c.height_m / 2),
                      xytext=(2, 2), textcoords="offset points", fontsize=7,
                      fontweight="bold", color="#222222",
                      bbox={"boxstyle": "round,pad=0.15", "facecolor": "white",
                            "edgecolor": "#8a7000", "linewidth": 0.5, "alpha": 0.9})
    ax_a.set_title(f"(a) {crew}: path (wider = later) and order of execution", fontsize=10)

    crew_multiples(right, paths, case,
                   [c for c in crew_ids if c in paths] + [c for c in paths if c not in crew_ids])
    key = [Patch(facecolor=PRECAST_FILL, edgecolor="#8a7000", label="precast component"),
           Patch(facecolor="none", edgecolor="#888888", label="other component"),
           Patch(facecolor="#dbe9f6", edgecolor="#4a7bb7", label="storage"),
           Line2D([], [], color=PATH_COLOUR, marker="o", linestyle="none",
                  label=f"{crew}: start"),
           Line2D([], [], color=PATH_COLOUR, marker="s", linestyle="none", label=f"{crew}: end"),
           Line2D([], [], color="#444444", marker="^", linestyle="none", label="crane")]
    fig.legend(handles=key, loc="outside lower center", ncol=len(key), fontsize=8,
               frameon=False)
    return save_png(fig, path)


STALL_TRAIL_S = 900.0  # how much of each crew's recent path a stall picture shows
STUCK_COLOUR = "#d62728"


def stall_picture(report: dict, case: Case, path: str | Path,
                  events: Sequence[Event] = ()) -> Path:
    """The floor where a run stalled, from its stall report (``report.stall_report``):
    the layout, each crew as a disc of its radius where it stands (red if it walks to a
    target, grey otherwise) with its id, a red star on the target it walks to, dashed red
    the way it means to walk (``way_m``, where the low level said it), and thin lines for
    each crew's last ``STALL_TRAIL_S`` s of ``position`` events. Writes a PNG to ``path``
    (atomically) and returns it."""
    hw, hh = case.plane.half_extents
    fig = Figure(figsize=(11, 11 * hh / hw + 1.2), layout="constrained")
    ax = fig.subplots()
    _draw_layout(ax, case, faint=True)
    start = report["time_s"] - STALL_TRAIL_S
    for trail in crew_paths(events).values():
        recent = trail[trail[:, 0] >= start]
        if len(recent) >= 2:
            ax.plot(recent[:, 1], recent[:, 2], color="#777777", linewidth=0.7, alpha=0.7)
    for crew in report["crews"]:
        _draw_stalled_crew(ax, crew)
    ax.set_title(f"Stalled at t = {report['time_s']:,.0f} s: no task moved on for "
                 f"{report['after_s']:,.0f} s", fontsize=11)
    key = [Line2D([], [], color=STUCK_COLOUR, marker="o", linestyle="none",
                  label="crew walking to a target"),
           Line2D([], [], color="#888888", marker="o", linestyle="none", label="other crew"),
           Line2D([], [], color=STUCK_COLOUR, marker="*", markersize=10, linestyle="none",
                  label="its target"),
           Line2D([], [], color=STUCK_COLOUR, linestyle="--", label="its planned way"),
           Line2D([], [], color="#777777", linewidth=0.7,
                  label=f"last {STALL_TRAIL_S:,.0f} s of path")]
    fig.legend(handles=key, loc="outside lower center", ncol=len(key), fontsize=8,
               frameon=False)
    return save_png(fig, path)


def _draw_stalled_crew(ax, crew: dict) -> None:
    """One crew of a stall report on the stall picture."""
    x, y = crew["position_m"]
    goal = crew.get("heading_for")
    colour = STUCK_COLOUR if goal else "#888888"
    ax.add_patch(Circle((x, y), crew.get("radius_m", 0.5), facecolor=colour, alpha=0.35,
                        edgecolor=colour, linewidth=1.2))
    ax.annotate(crew["crew"], (x, y), xytext=(0, 9), textcoords="offset points", ha="center",
                fontsize=8, fontweight="bold", color=colour)
    if goal is None:
        return
    way = np.asarray(crew.get("way_m") or [], dtype=float)
    if len(way) >= 2:
        ax.plot(way[:, 0], way[:, 1], "--", color=STUCK_COLOUR, linewidth=1.2)
    gx, gy = goal["position_m"]
    ax.plot([gx], [gy], marker="*", markersize=13, color=STUCK_COLOUR, linestyle="none")
    ax.annotate(goal["task"] or goal["target"], (gx, gy), xytext=(6, -10),
                textcoords="offset points", fontsize=7, color=STUCK_COLOUR)


def crew_multiples(fig, paths: dict, case: Case, order: list[str]) -> list:
    """Fig. 11 (b): one small panel per crew (in ``order``), its path over the faint layout,
    coloured from early (light) to late (dark), so that no crew's path hides another's.
    Returns the axes."""
    from matplotlib import colormaps

    cols = min(3, max(1, len(order)))
    rows = max(1, -(-len(order) // cols))
    axes = np.atleast_1d(fig.subplots(rows, cols, sharex=True, sharey=True)).ravel()
    cmap = colormaps["viridis_r"]
    for ax, cid in zip(axes, order, strict=False):
        _draw_layout(ax, case, faint=True)
        p = paths[cid]
        if len(p) >= 2:
            t = (p[:, 0] - p[0, 0]) / max(p[-1, 0] - p[0, 0], 1e-9)
            segments = np.stack([p[:-1, 1:3], p[1:, 1:3]], axis=1)
            ax.add_collection(LineCollection(segments, colors=cmap(0.15 + 0.85 * t[1:]),
                                             linewidths=0.9))
        ax.set_title(cid, fontsize=8, pad=2)
        ax.set_xlabel("")
        ax.set_ylabel("")
        ax.tick_params(labelsize=6)
    for ax in axes[len(order):]:
        ax.set_axis_off()
    if not order:
        axes[0].text(0.5, 0.5, "no position events", ha="center", va="center",
                     transform=axes[0].transAxes, fontsize=9)
    fig.suptitle("(b) each crew's path (light early, dark late)", fontsize=10)
    return list(axes[:len(order)])


# ------------------------------------------------------------------------------------------
# A run folder, GIFs and the command line.

CHART_FILES = ("gantt_agents.png", "gantt_tasks.png", "trajectories.png", "resource_profile.png")


def draw_run(run_dir: str | Path, case: Case) -> list[Path]:
    """Draw Figs. 9-11 and the resource profile of a saved run from ``run_dir/events.csv``
    into ``run_dir``.

    How the run ended (:func:`run_end`) comes from ``run_dir/summary.json`` when there is one,
    else from the log and the case's number of tasks; a case with a working calendar (its
    ``case.json`` keeps the one the run used) gives both Gantt charts and the resource
    profile a date axis. Returns the paths of ``gantt_agents.png``, ``gantt_tasks.png``,
    ``resource_profile.png`` (:func:`resource_profile`) and ``trajectories.png`` (not drawn
    for a run on the event floor: see the module doc). Raises
    FileNotFoundError when there is no ``events.csv`` and ValueError when the log names tasks
    that ``case`` does not define (the run was made with another case).
    """
    run_dir = Path(run_dir)
    log = run_dir / "events.csv"
    if not log.is_file():
        raise FileNotFoundError(f"{log}: no event log; fix: pass a run folder written with "
                                "env.log.write_csv(run_dir / 'events.csv')")
    events = read_csv(log)
    unknown = unknown_tasks(events, case)
    if unknown:
        shown = ", ".join(unknown[:5]) + (", ..." if len(unknown) > 5 else "")
        raise ValueError(f"{log}: {len(unknown)} task(s) not in case {case.case.name!r} "
                         f"({shown}); fix: pass the case the run was made with")
    summary = read_summary(run_dir)
    event_floor = (summary or {}).get("fidelity") == "event"
    name = case.case.name + (" (event floor)" if event_floor else "")
    end = run_end(events, len(case.tasks), summary)
    return [
        gantt_agents(events, run_dir / CHART_FILES[0], title=f"Crews' activities: {name}",
                     end=end, calendar=case.calendar),
        gantt_tasks(events, run_dir / CHART_FILES[1], case=case, title=f"Tasks: {name}",
                    end=end),
        resource_profile(events, case, run_dir / CHART_FILES[3],
                         title=f"Resources over time: {name}", end=end),
        # paths need positions along the walks, which the event floor does not have
        *([] if event_floor else [trajectories(events, case, run_dir / CHART_FILES[2])]),
    ]


class GifStream:
    """A looping GIF written to disk frame by frame, so that a long animation never sits in
    memory (``cmdp-simulate --gif`` held every frame: about 1.4 GB at its peak).

    Frames go to a temporary file beside ``path``; :meth:`close` finishes it and renames it to
    ``path``, and :meth:`abort` (or leaving a ``with`` block by an exception, Ctrl-C included)
    deletes it: a crash leaves no half GIF. Only the last written frame and one pending frame
    are held. A frame equal to the one before lengthens it (as Pillow's own GIF writer merges
    them: the playing time is unchanged); a changed frame stores only the rectangle that
    changed, each with its own 256-colour palette (Pillow's adaptive palette, as for a whole
    GIF).

    Why not imageio's writer: with Pillow 13, imageio 2.38's v3 Pillow plugin keeps every frame
    until the file is closed, and its legacy streaming GIF writer (``GIF-PIL``) writes a file
    Pillow cannot read (it refuses Pillow 10.1+ for that reason). The frames are encoded with
    Pillow's own GIF encoder (``GifImagePlugin.getdata``); only the file's header, loop
    extension and trailer are written here (GIF89a).

    Args:
        path: the GIF to write.
        duration_s_per_frame: seconds a frame shows, rounded to the GIF's hundredths.
    """

    def __init__(self, path: str | Path, duration_s_per_frame: float):
        import os
        import tempfile

        if not duration_s_per_frame > 0:
            raise ValueError(f"duration_s_per_frame must be positive, not {duration_s_per_frame}")
        self.path = Path(path)
        self.centis = max(1, round(duration_s_per_frame * 100))
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, self._tmp = tempfile.mkstemp(dir=self.path.parent, prefix=f".{self.path.name}.",
                                         suffix=".tmp")
        self._file = os.fdopen(fd, "wb")
        self._shape: tuple | None = None
        self._written: np.ndarray | None = None  # what a viewer shows after the last frame
        self._pending: np.ndarray | None = None  # the newest frame, its length still growing
        self._pending_centis = 0
        self.frames = 0  # frames given
        self.stored = 0  # frames in the file (equal consecutive frames merged)

    def append(self, frame: np.ndarray) -> None:
        """Add one (H, W, 3) uint8 frame (every frame of one shape)."""
        f = np.asarray(frame)
        if self._shape is None and not (f.dtype == np.uint8 and f.ndim == 3 and f.shape[2] == 3):
            self.abort()
            raise ValueError(f"frame 0 is {f.dtype} {f.shape}; fix: every frame must be uint8 "
                             "of one shape (H, W, 3)")
        if self._shape is not None and (f.dtype != np.uint8 or f.shape != self._shape):
            self.abort()
            raise ValueError(f"frame {self.frames} is {f.dtype} {f.shape}; fix: every frame "
                             f"must be uint8 of one shape (H, W, 3), like frame 0 {self._shape}")
        if self._shape is None:
            self._shape = f.shape
            self._header(f.shape[1], f.shape[0])
        self.frames += 1
        if self._pending is not None and np.array_equal(f, self._pending):
            self._pending_centis += self.centis
            return
        self._flush()
        self._pending, self._pending_centis = f.copy(), self.centis

    def _header(self, width: int, height: int) -> None:
        o16 = _le16
        self._file.write(b"GIF89a" + o16(width) + o16(height) + bytes((0, 0, 0)))
        self._file.write(b"!\xff\x0bNETSCAPE2.0\x03\x01" + o16(0) + b"\x00")  # loop forever

    def _flush(self) -> None:
        """Write the pending frame: the rectangle that changed since the last written one."""
        from PIL import GifImagePlugin, Image

        new = self._pending
        if new is None:
            return
        top, left, bottom, right = 0, 0, new.shape[0], new.shape[1]
        if self._written is not None:
            changed = np.any(new != self._written, axis=2)
            rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
            top, bottom, left, right = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
        image = Image.fromarray(np.ascontiguousarray(new[top:bottom, left:right]))
        image = image.convert("P", palette=Image.Palette.ADAPTIVE)
        while self._pending_centis > 0:  # a delay holds at most 65535 hundredths
            centis = min(self._pending_centis, 65535)
            for chunk in GifImagePlugin.getdata(
                    image, (int(left), int(top)), duration=10 * centis, disposal=1,
                    include_color_table=True):
                self._file.write(chunk)
            self._pending_centis -= centis
            self.stored += 1
        self._written, self._pending = new, None

    def close(self) -> Path:
        """Finish the file and move it to ``path``; returns the path."""
        import os

        if self._pending is None and self._written is None:
            self.abort()
            raise ValueError("no frames to write; fix: pass at least one (H, W, 3) uint8 frame")
        try:
            self._flush()
            self._file.write(b";")
            self._file.close()
            os.chmod(self._tmp, 0o644)
            os.replace(self._tmp, self.path)
        except BaseException:
            self.abort()
            raise
        return self.path

    def abort(self) -> None:
        """Delete the unfinished file (safe to call twice)."""
        import os

        self._file.close()
        if os.path.exists(self._tmp):
            os.unlink(self._tmp)

    def __enter__(self) -> GifStream:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()


def _le16(value: int) -> bytes:
    return int(value).to_bytes(2, "little")


def write_gif(frames: Iterable[np.ndarray], path: str | Path,
              duration_s_per_frame: float) -> Path:
    """Write (H, W, 3) uint8 frames as a looping GIF, atomically, one frame at a time
    (:class:`GifStream`); returns the path.

    GIF stores durations in hundredths of a second, so ``duration_s_per_frame`` is rounded to
    that. Consecutive identical frames are merged into one longer frame (the playing time
    is unchanged), so the file may hold fewer frames than were given.
    """
    with GifStream(path, duration_s_per_frame) as gif:
        for frame in frames:
            gif.append(frame)
    return gif.path


def run_case_path(run_dir: Path) -> Path | None:
    """The resolved case ``cmdp-simulate`` saved with a run: ``case.json`` in the run folder,
    or in its parent (a ``seed-K/`` folder of a multi-episode run); None when there is none."""
    for folder in (run_dir, run_dir.parent):
        if (folder / "case.json").is_file():
            return folder / "case.json"
    return None


def load_run_case(path: Path | None) -> Case:
    """A case from a TOML case file, a resolved ``case.json``, or None (the built-in case).

    Raises ``cmdp_pymunk.cases.load.CaseError`` for a file that cannot be read or is not a valid
    case.
    """
    from cmdp_pymunk.cases.load import CaseError, case_from_dict, load_case

    if path is None or path.suffix.lower() != ".json":
        return load_case(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise CaseError(str(path), [f"cannot read the resolved case ({err}); fix: pass the "
                                    "run's case file with --case"]) from None
    return case_from_dict(data, path.name)


def main(argv: list[str] | None = None) -> int:
    """``python -m media.charts RUN_DIR [--case PATH]``: redraw a saved run's charts."""
    from cmdp_pymunk import add_version_flag

    parser = argparse.ArgumentParser(prog="python -m media.charts",
                                     description="Redraw Figs. 9-11 and the resource "
                                                 "profile of a saved run from its events.csv.")
    add_version_flag(parser)
    parser.add_argument("run_dir", type=Path, help="run folder holding events.csv")
    parser.add_argument("--case", type=Path, default=None,
                        help="the run's case: a case file (TOML) or a resolved case.json; "
                             "default: case.json in RUN_DIR or its parent, else the built-in "
                             "case")
    ns = parser.parse_args(argv)
    prog = parser.prog
    if not (ns.run_dir / "events.csv").is_file():
        print(f"{prog}: {ns.run_dir / 'events.csv'} does not exist; fix: pass a run folder "
              "that holds the run's events.csv (written by env.log.write_csv)", file=sys.stderr)
        return 2
    from cmdp_pymunk.cases.load import CaseError

    try:
        case = load_run_case(ns.case if ns.case is not None else run_case_path(ns.run_dir))
    except CaseError as err:
        print(f"{prog}: {err}", file=sys.stderr)
        return 2
    try:
        written = draw_run(ns.run_dir, case)
    except ValueError as err:
        print(f"{prog}: {err}", file=sys.stderr)
        return 2
    for p in written:
        print(f"{prog}: wrote {p}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
