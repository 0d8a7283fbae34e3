"""The Gantt charts of a run (section 5.2, Figs. 9 and 10) and its resource profile.

- :func:`gantt_agents`, Fig. 9: one row per crew, a bar per ``activity`` interval: idle grey
  (a lighter grey per cause: predecessor, task area, no target), navigating and deregistered
  (walking to the outlet) yellow, tasking red, fetching and waiting for the crane green.
- :func:`gantt_tasks`, Fig. 10: one bar per task from its start to its finish, pauses drawn as
  lighter segments, tasks sorted by start time from the top and labelled with their ids,
  coloured by task type.
- :func:`resource_profile`: the resources over time, counted from the log: crews busy per
  crew type (tasking, fetching material, waiting for the crane; ``timeline.crews_busy``),
  stacked, and the crane's lifts landed per hour (per 15 minutes in a run under 4 h) with its
  busy share (``timeline.crane_per_bin``).

Each has a ``_figure`` twin that returns the ``matplotlib.figure.Figure`` unsaved. The
intervals they draw are read from the log in ``media.timeline`` (no plotting there); the
charts share time axes, so they sit together here.

Both Gantt charts mark how the run ended (``timeline.RunEnd``): a finished run's makespan (the
last ``task_finish``) as a dashed line, or, for a run that stalled or reached its time limit,
a dotted red line where it stopped, labelled and added to the title as "stalled at t = 0.61 h
(2191 s), 2 of 3 tasks ended" ("time limit at ...", or "unfinished at ..." when only the log
and the case are known).

With disruptions (docs/disruptions.md), both Gantt charts shade a band across the chart for
every crane breakdown, late delivery and weather stop (``timeline.disruption_intervals``), and
a crew kept from working shows the disruption's own idle colour in Fig. 9 (an absence
hatched).

Times in the log are simulated seconds; the charts' time axes are in hours. With a working
calendar both Gantt charts get a date axis on top (``figures.date_ticks``), and the makespan's
legend entry (or where an unfinished run stopped) its date.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from cmdp_pymunk.cases.load import Calendar, Case
from cmdp_pymunk.events import Event
from cmdp_pymunk.schedule import log_end_s, makespan_s, paused_at_end, task_bars
from cmdp_pymunk.workcalendar import calendar_datetime
from media.figures import _date_axis, save_png
from media.timeline import (
    FINISHED,
    HOUR_S,
    RunEnd,
    activity_intervals,
    crane_lifts,
    crane_per_bin,
    crews_busy,
    disruption_intervals,
    run_end,
    task_types,
)

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
LIFT_STYLE = {"material": {"color": "#2ca02c", "label": "material lifts"},
              "task": {"color": "#98df8a", "label": "hoisting assists"}}


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
