"""Charts of many episodes of one strategy (``cmdp-simulate --episodes N``), for a planner.

- :func:`makespan_histogram`: the finished episodes' makespans, with P50, P80 and P90 marked
  (``makespans.json`` holds the numbers).
- :func:`s_curve`: tasks ended over time, every episode's curve thin, the median over episodes
  thick, the band between the 10th and 90th percentile over episodes at each time, and the
  P50/P80/P90 makespans where the curves reach the total.
- :func:`draw_episodes` draws both into a run folder.

Times in seconds in, hours on the axes. Rendered off-screen and written atomically, like
``media.charts``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from cmdp_pymunk.rollout import PERCENTILES
from cmdp_pymunk.schedule import tasks_ended
from media.charts import HOUR_S, save_png

EPISODE_FILES = ("makespan_histogram.png", "s_curve.png")
BAND = (10, 90)  # the S-curve's band: percentiles over episodes at each time
CURVE_POINTS = 400
PERCENTILE_STYLE = {50: "-", 80: "--", 90: ":"}


def _mark_percentiles(ax, stats: dict) -> None:
    for q in PERCENTILES:
        value = stats.get(f"p{q}_s")
        if value is not None:
            ax.axvline(value / HOUR_S, color="black", linestyle=PERCENTILE_STYLE[q],
                       linewidth=1.1, label=f"P{q} {value:,.0f} s")


def makespan_histogram(stats: dict, path: str | Path) -> Path:
    """A histogram of the finished episodes' makespans, P50/P80/P90 as vertical lines.

    Args:
        stats: ``rollout.makespan_stats`` of the episodes (``makespans_s``, None for an
            unfinished episode; ``p50_s``, ``p80_s``, ``p90_s``).
        path: the PNG to write.
    """
    done = np.array([m for m in stats["makespans_s"] if m], dtype=float)
    fig = Figure(figsize=(7, 4), layout="constrained")
    ax = fig.add_subplot()
    if len(done):
        ax.hist(done / HOUR_S, bins="auto", color="#9ecae1", edgecolor="#3182bd")
        _mark_percentiles(ax, stats)
        ax.legend(fontsize=8)
    else:
        ax.text(0.5, 0.5, "no episode finished", ha="center", va="center",
                transform=ax.transAxes)
    ax.set_xlabel("makespan (h)")
    ax.set_ylabel("episodes")
    ax.set_title(f"Makespan over {len(stats['makespans_s'])} episodes "
                 f"({len(done)} finished)")
    ax.grid(axis="y", alpha=0.3)
    return save_png(fig, path)


def s_curve(finishes: Sequence[Sequence[float]], total_tasks: int, path: str | Path,
            stats: dict | None = None) -> Path:
    """Tasks ended over time: each episode thin, the median thick, a 10-90 % band.

    Args:
        finishes: per episode, its task finish times (``schedule.finish_times``), seconds.
        total_tasks: the case's number of tasks (a horizontal line).
        path: the PNG to write.
        stats: ``rollout.makespan_stats`` of the same episodes, to mark P50/P80/P90.
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
        _mark_percentiles(ax, stats)
    ax.set_xlim(0, hours[-1] * 1.01)
    ax.set_ylim(0, total_tasks * 1.04)
    ax.set_xlabel("simulated time (h)")
    ax.set_ylabel(f"tasks ended (of {total_tasks})")
    ax.set_title("Tasks ended over time (S-curve)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    return save_png(fig, path)


def draw_episodes(folder: str | Path, stats: dict, finishes: Sequence[Sequence[float]],
                  total_tasks: int) -> list[Path]:
    """``makespan_histogram.png`` and ``s_curve.png`` into ``folder``; returns their paths."""
    folder = Path(folder)
    return [makespan_histogram(stats, folder / EPISODE_FILES[0]),
            s_curve(finishes, total_tasks, folder / EPISODE_FILES[1], stats)]
