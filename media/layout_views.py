"""The site layout seen from above, with the crews' paths on it (section 5.2, Fig. 11).

- :func:`trajectories`, Fig. 11: (a) one crew's path (the hoisting crew HIC by default,
  :func:`default_crew`), wider as time goes on (:func:`widths_by_time`), with the components
  it worked on numbered in the order it started them; (b) every crew's path, one small panel
  per crew (:func:`crew_multiples`).
- :func:`stall_picture`: the floor where a run stalled (``report.stall_report``): every crew
  where it stands, drawn to its size, a walking crew's target and the way it means to walk,
  and its last minutes of path from the log.

Both draw the plane's layout (``_draw_layout``: storages, components, the outlet, the crane)
in the case's coordinates: metres, the plane's origin at its centre, y up. Apart from the
Gantt charts (``media.gantt``) because they are drawn in space, not in time; the paths they
draw are read from the log in ``media.timeline``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.collections import LineCollection, PatchCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch, Rectangle

from cmdp_pymunk.cases.load import Case
from cmdp_pymunk.events import Event
from media.figures import save_png
from media.timeline import crew_paths, execution_order

PRECAST_FILL = "#f5d742"
PATH_COLOUR = "#d95f02"  # panel (a): orange reads on both the yellow and the grey components


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
