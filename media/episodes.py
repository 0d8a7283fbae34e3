"""Charts of many episodes of one strategy (``cmdp-simulate --episodes N``), for a planner.

- :func:`makespan_histogram`: the finished episodes' makespans, with P50, P80 and P90 marked
  (``makespans.json`` holds the numbers).
- :func:`s_curve`: tasks ended over time, every episode's curve thin, the median over episodes
  thick, the band between the 10th and 90th percentile over episodes at each time, and the
  P50/P80/P90 makespans where the curves reach the total; when an episode stalled or reached
  its time limit, the title says how many finished (:func:`s_curve_title`).
- :func:`draw_episodes` draws both into a run folder.
- :func:`draw_strategy_episodes` draws the same two for a comparison (``cmdp-evaluate``):
  the histograms one panel per strategy on a shared time axis, the S-curves one colour per
  strategy on one axis, so a planner reads which strategy ends the floor sooner and surer.

Episodes of the event floor (``fidelity`` "event" in the stats or the summary entries;
docs/event-floor.md) say so in the titles (:func:`floor_note`), so that no chart of it passes
for the pymunk floor's. Times in seconds in, hours on the axes; the P50/P80/P90 lines are
labelled in hours with the seconds beside them (``P80 9.17 h (33,000 s)``). With a working
calendar (``cmdp-simulate --start``, the case's ``[calendar]``) the hours are simulated working
hours, a date axis runs on top (``media.figures.date_ticks``) and the percentiles' labels end
with their dates. Rendered off-screen and written atomically (``media.figures.save_png``).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from cmdp_pymunk.cases.load import Calendar
from cmdp_pymunk.report import PERCENTILES
from cmdp_pymunk.schedule import tasks_ended
from cmdp_pymunk.workcalendar import calendar_datetime
from media.figures import _date_axis, save_png
from media.timeline import HOUR_S

EPISODE_FILES = ("makespan_histogram.png", "s_curve.png")
BAND = (10, 90)  # the S-curve's band: percentiles over episodes at each time
CURVE_POINTS = 400
PERCENTILE_STYLE = {50: "-", 80: "--", 90: ":"}


def floor_note(stats: dict | None) -> str:
    """`` (event floor)`` for the stats or summary entry of episodes on the event floor."""
    return " (event floor)" if (stats or {}).get("fidelity") == "event" else ""


def percentile_label(q: int, value_s: float, calendar: Calendar | None = None) -> str:
    """``P80 9.17 h (33,000 s)`` on an axis of hours; with a calendar, its date too:
    ``P80 9.17 h (33,000 s), Tue 06 Jan 09:10``."""
    label = f"P{q} {value_s / HOUR_S:.2f} h ({value_s:,.0f} s)"
    if calendar is not None:
        label += f", {calendar_datetime(calendar, value_s):%a %d %b %H:%M}"
    return label


def _mark_percentiles(ax, stats: dict, color: str = "black",
                      calendar: Calendar | None = None) -> None:
    for q in PERCENTILES:
        value = stats.get(f"p{q}_s")
        if value is not None:
            ax.axvline(value / HOUR_S, color=color, linestyle=PERCENTILE_STYLE[q],
                       linewidth=1.1, label=percentile_label(q, value, calendar))


def makespan_histogram(stats: dict, path: str | Path, calendar: Calendar | None = None) -> Path:
    """A histogram of the finished episodes' makespans, P50/P80/P90 as vertical lines; with
    ``calendar``, a date axis of the finish on top.

    Args:
        stats: ``report.makespan_stats`` of the episodes (``makespans_s``, None for an
            unfinished episode; ``p50_s``, ``p80_s``, ``p90_s``).
        path: the PNG to write.
    """
    done = np.array([m for m in stats["makespans_s"] if m], dtype=float)
    fig = Figure(figsize=(7, 4), layout="constrained")
    ax = fig.add_subplot()
    if len(done):
        ax.hist(done / HOUR_S, bins="auto", color="#9ecae1", edgecolor="#3182bd")
        _mark_percentiles(ax, stats, calendar=calendar)
        ax.legend(fontsize=8)
        _date_axis(ax, calendar, float(done.max()))
    else:
        ax.text(0.5, 0.5, "no episode finished", ha="center", va="center",
                transform=ax.transAxes)
    ax.set_xlabel("makespan (h of simulated working time)" if calendar is not None
                  else "makespan (h)")
    ax.set_ylabel("episodes")
    ax.set_title(f"Makespan over {len(stats['makespans_s'])} episodes "
                 f"({len(done)} finished){floor_note(stats)}")
    ax.grid(axis="y", alpha=0.3)
    return save_png(fig, path)


def s_curve(finishes: Sequence[Sequence[float]], total_tasks: int, path: str | Path,
            stats: dict | None = None, calendar: Calendar | None = None) -> Path:
    """Tasks ended over time: each episode thin, the median thick, a 10-90 % band.

    Args:
        finishes: per episode, its task finish times (``schedule.finish_times``), seconds.
        total_tasks: the case's number of tasks (a horizontal line).
        path: the PNG to write.
        stats: ``report.makespan_stats`` of the same episodes, to mark P50/P80/P90.
        calendar: the run's working calendar: a date axis on top, dated percentiles.
    """
    end_s = max((f[-1] for f in finishes if len(f)), default=1.0)
    times = np.linspace(0.0, end_s, CURVE_POINTS)
    ended = tasks_ended(finishes, times)
    hours = times / HOUR_S
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.add_subplot()
    for row in ended:
        ax.plot(hours, row, color="#9e9e9e", linewidth=0.6, alpha=0.5)
    if len(ended):
        low, high = np.percentile(ended, BAND, axis=0)
        ax.fill_between(hours, low, high, color="#fdae6b", alpha=0.45, linewidth=0,
                        label=f"{BAND[0]}-{BAND[1]} % of episodes")
        ax.plot(hours, np.median(ended, axis=0), color="#e6550d", linewidth=2.0,
                label=f"median of {len(ended)} episodes")
    ax.axhline(total_tasks, color="#444444", linewidth=0.8)
    if stats is not None:
        _mark_percentiles(ax, stats, calendar=calendar)
    ax.set_xlim(0, hours[-1] * 1.01)
    ax.set_ylim(0, total_tasks * 1.04)
    ax.set_xlabel("simulated time (h)")
    _date_axis(ax, calendar, end_s)  # with a calendar: working hours below, dates on top
    ax.set_ylabel(f"tasks ended (of {total_tasks})")
    ax.set_title(s_curve_title(finishes, total_tasks, stats is not None) + floor_note(stats))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    return save_png(fig, path)


def s_curve_title(finishes: Sequence[Sequence[float]], total_tasks: int,
                  percentiles: bool = True) -> str:
    """The S-curve's title; when an episode stalled or reached its time limit (fewer than
    ``total_tasks`` finishes), it says how many of the episodes finished, and that P50/P80/P90
    are over those."""
    title = "Tasks ended over time (S-curve)"
    done = sum(len(f) >= total_tasks for f in finishes)
    if done < len(finishes):
        title += f": {done} of {len(finishes)} episodes finished"
        if percentiles:
            title += "; P50/P80/P90 over those"
    return title


def draw_episodes(folder: str | Path, stats: dict, finishes: Sequence[Sequence[float]],
                  total_tasks: int, calendar: Calendar | None = None) -> list[Path]:
    """``makespan_histogram.png`` and ``s_curve.png`` into ``folder`` (dated with
    ``calendar``); returns their paths."""
    folder = Path(folder)
    return [makespan_histogram(stats, folder / EPISODE_FILES[0], calendar),
            s_curve(finishes, total_tasks, folder / EPISODE_FILES[1], stats, calendar)]


def strategy_stats(entry: dict) -> dict:
    """P50/P80/P90 of a ``training.runs.paired.summarize`` entry under ``_mark_percentiles``'s
    keys (``p50_s`` ...)."""
    return {f"p{q}_s": entry.get(f"makespan_p{q}_s") for q in PERCENTILES}


def _strategy_groups(rows: Sequence[dict], summary: Sequence[dict]) -> list[tuple]:
    """(label, rows, summary entry) per (strategy, low level), in the summary's order; the low
    level is named only when the comparison has more than one."""
    navigators = {e["navigator"] for e in summary}
    out = []
    for e in summary:
        group = [r for r in rows
                 if (r["strategy"], r["navigator"]) == (e["strategy"], e["navigator"])]
        label = e["strategy"] if len(navigators) == 1 else f"{e['strategy']} / {e['navigator']}"
        out.append((label, group, e))
    return out


def strategy_histograms(rows: Sequence[dict], summary: Sequence[dict], path: str | Path,
                        lower_bound_s: float | None = None) -> Path:
    """The finished episodes' makespans, one panel per strategy (and low level) on one shared
    time axis, each with its P50/P80/P90 from ``summary`` and the lower bound.

    Args:
        rows: ``cmdp-evaluate``'s episode rows (``strategy``, ``navigator``, ``makespan_s``,
            ``finished``).
        summary: ``training.runs.paired.summarize`` of the same rows.
        path: the PNG to write.
        lower_bound_s: drawn as a grey dashed line when given.
    """
    groups = _strategy_groups(rows, summary)
    fig = Figure(figsize=(8, 1.2 + 1.9 * len(groups)), layout="constrained")
    axes = fig.subplots(len(groups), 1, sharex=True, squeeze=False)[:, 0]
    done_all = [r["makespan_s"] for r in rows if r["finished"] and r["makespan_s"]]
    edges = np.histogram_bin_edges(np.array(done_all, dtype=float) / HOUR_S, bins="auto") \
        if done_all else None
    for i, (ax, (label, group, entry)) in enumerate(zip(axes, groups, strict=True)):
        colour = f"C{i % 10}"
        done = np.array([r["makespan_s"] for r in group if r["finished"] and r["makespan_s"]],
                        dtype=float)
        if len(done):
            ax.hist(done / HOUR_S, bins=edges, color=colour, alpha=0.45, edgecolor=colour)
            _mark_percentiles(ax, strategy_stats(entry), colour)
        else:
            ax.text(0.5, 0.5, "no episode finished", ha="center", va="center",
                    transform=ax.transAxes)
        if lower_bound_s:
            ax.axvline(lower_bound_s / HOUR_S, color="#777777", linestyle="-.", linewidth=1,
                       label=f"lower bound {lower_bound_s:,.0f} s")
        ax.set_title(f"{label}: {len(done)} of {len(group)} episodes finished", fontsize=9,
                     loc="left")
        ax.set_ylabel("episodes")
        ax.yaxis.get_major_locator().set_params(integer=True)
        ax.grid(axis="y", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("makespan (h)")
    fig.suptitle("Makespan per strategy, P50 / P80 / P90 marked"
                 + floor_note(summary[0] if summary else None), fontsize=11)
    return save_png(fig, path)


def strategy_s_curves(rows: Sequence[dict], summary: Sequence[dict], total_tasks: int,
                      path: str | Path) -> Path:
    """Tasks ended over time, one colour per strategy (and low level): the median over its
    episodes as a line, the 10-90 % band over its episodes at each time shaded.

    Args:
        rows: ``cmdp-evaluate``'s episode rows with ``task_end_times_s`` (rows without it,
            from a run before the field existed, are left out).
        summary: ``training.runs.paired.summarize`` of the same rows (order and labels).
        total_tasks: the case's number of tasks (a horizontal line).
        path: the PNG to write.
    """
    key = "task_end_times_s"
    groups = [(label, [r[key] for r in group if r.get(key) is not None], entry)
              for label, group, entry in _strategy_groups(rows, summary)]
    end_s = max((f[-1] for _, finishes, _ in groups for f in finishes if len(f)), default=1.0)
    times = np.linspace(0.0, end_s, CURVE_POINTS)
    hours = times / HOUR_S
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.add_subplot()
    for i, (label, finishes, entry) in enumerate(groups):
        if not finishes:
            continue
        colour = f"C{i % 10}"
        ended = tasks_ended(finishes, times)
        low, high = np.percentile(ended, BAND, axis=0)
        ax.fill_between(hours, low, high, color=colour, alpha=0.18, linewidth=0)
        p80 = entry.get("makespan_p80_s")
        ax.plot(hours, np.median(ended, axis=0), color=colour, linewidth=2.0,
                label=f"{label}: median of {len(finishes)} seed{'s' if len(finishes) > 1 else ''}"
                      + (f", {percentile_label(80, p80)}" if p80 is not None else ""))
    ax.axhline(total_tasks, color="#444444", linewidth=0.8)
    ax.set_xlim(0, hours[-1] * 1.01)
    ax.set_ylim(0, total_tasks * 1.04)
    ax.set_xlabel("simulated time (h)")
    ax.set_ylabel(f"tasks ended (of {total_tasks})")
    ax.set_title(f"Tasks ended over time per strategy (line: median; band: {BAND[0]}-{BAND[1]} "
                 "% of episodes)" + floor_note(summary[0] if summary else None), fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    return save_png(fig, path)


def draw_strategy_episodes(folder: str | Path, rows: Sequence[dict], summary: Sequence[dict],
                           total_tasks: int, lower_bound_s: float | None = None) -> list[Path]:
    """``makespan_histogram.png`` and ``s_curve.png`` of a comparison into ``folder``."""
    folder = Path(folder)
    return [strategy_histograms(rows, summary, folder / EPISODE_FILES[0], lower_bound_s),
            strategy_s_curves(rows, summary, total_tasks, folder / EPISODE_FILES[1])]
