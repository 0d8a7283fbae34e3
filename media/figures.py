"""What every chart of a run shares: a figure written as a PNG, and the date axis.

- :func:`save_png`: a ``matplotlib.figure.Figure`` rendered by its own Agg canvas into memory,
  then written atomically (``cmdp_pymunk.events.write_atomic``). Figures are never made
  through ``pyplot``: no global backend is switched and no figure is registered anywhere, so
  nothing needs closing and nothing leaks.
- :func:`date_ticks` (and ``_date_axis``): with a working calendar (the case's ``calendar``;
  ``cmdp_pymunk.workcalendar``) a chart keeps its axis of simulated (working) hours and gets a
  date axis on top: second 0 with its date and time, then each working day's opening,
  labelled with its date; the axis label names the start and the working time.

Apart from the charts themselves because the Gantt charts (``media.gantt``), the plan views
(``media.layout_views``) and the episodes' charts (``media.episodes``) all use them.
"""

from __future__ import annotations

import io
from pathlib import Path

from matplotlib.figure import Figure

from cmdp_pymunk.cases.load import Calendar
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.workcalendar import describe, first_working_moment, working_day_openings
from media.timeline import HOUR_S

DPI = 110
MAX_DATE_TICKS = 12  # beyond this many working days the date axis labels every k-th


def save_png(fig: Figure, path: str | Path) -> Path:
    """Render the figure to PNG in memory, then write it atomically."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    path = Path(path)
    write_atomic(path, buf.getvalue())
    return path


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
