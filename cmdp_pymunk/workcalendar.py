"""Simulated seconds as calendar dates: a case's working calendar (``cases.model.Calendar``).

The rule. Simulated time counts working time only: the crews work from the opening to the
closing of the calendar's working hours, on its working days that are not holidays, and the
clock stands still in between (nights, days off, holidays). Second 0 is the calendar's start
when the start is working time (``[opening, closing)`` of a working day), else the next
working moment: the opening later that day, or of the next working day (a start at the closing
moves too). Second t is the earliest moment by which t working seconds have passed since
second 0, so a moment exactly at a day's closing is that day's closing, not the next opening.

Example (Friday 2026-01-09 15:00, "08:00-16:00", Mon-Fri): second 3600 is Fri 16:00, second
3601 is Mon 2026-01-12 08:00:01; with Monday a holiday, Tue 2026-01-13 08:00:01.

Pure functions of the calendar; the schedule table, the charts, ``summary.json`` and the 4D
export call them.
"""

from __future__ import annotations

import datetime as dt
import functools

from .cases.model import WEEKDAYS, Calendar

_DAY = dt.timedelta(days=1)


def working_window(calendar: Calendar, day: dt.date) -> tuple[dt.datetime, dt.datetime] | None:
    """The working time ``[opening, closing)`` of ``day``, or None on a day off or holiday."""
    if WEEKDAYS[day.weekday()] not in calendar.working_days or day in calendar.holidays:
        return None
    midnight = dt.datetime.combine(day, dt.time())
    return (midnight + dt.timedelta(seconds=calendar.opening_s),
            midnight + dt.timedelta(seconds=calendar.closing_s))


def first_working_moment(calendar: Calendar) -> dt.datetime:
    """Simulated second 0: the start if it is working time, else the next working moment."""
    return _working_days(calendar).zero


def _first_working_moment(calendar: Calendar) -> dt.datetime:
    start = calendar.start
    day = start.date()
    while True:  # a working day comes: there is one a week and finitely many holidays
        window = working_window(calendar, day)
        if window is not None and start < window[1]:
            return max(start, window[0])
        day += _DAY


class _WorkingDays:
    """A calendar's second 0 and its working days from there, each as (the moment its
    working time begins, its working seconds), found once per calendar and extended as later
    seconds are asked for: a schedule asks for ~350 dates a floor, and walking the days and
    parsing the hours again for each was most of writing it."""

    def __init__(self, calendar: Calendar) -> None:
        self.calendar = calendar
        self.zero = _first_working_moment(calendar)
        self.days: list[tuple[dt.datetime, float]] = []
        self._next = self.zero.date()

    def extend(self) -> None:
        """Appends the next working day."""
        while True:
            day, self._next = self._next, self._next + _DAY
            window = working_window(self.calendar, day)
            if window is not None:
                begin = max(window[0], self.zero)
                self.days.append((begin, (window[1] - begin).total_seconds()))
                return


@functools.lru_cache(maxsize=16)  # a Calendar is frozen and hashed by its value
def _working_days(calendar: Calendar) -> _WorkingDays:
    return _WorkingDays(calendar)


_LAST_ASKED: tuple = (None, None)  # (the calendar last asked, its working days)


def calendar_datetime(calendar: Calendar, seconds: float) -> dt.datetime:
    """The date and time of simulated second ``seconds`` (the module's rule).

    Walks day by day from second 0, taking each working day's working time until ``seconds``
    of it have passed; the moment is the earliest at which they have (a closing, not the next
    opening, when they end exactly with a day).

    Args:
        calendar: the working calendar.
        seconds: simulated (working) seconds from second 0, at least 0.

    Returns:
        The local date and time, to the microsecond.
    """
    if not seconds >= 0:
        raise ValueError(f"simulated seconds must be at least 0, got {seconds!r}")
    global _LAST_ASKED
    last = _LAST_ASKED  # one tuple: read whole, even with threads
    if last[0] is calendar:  # the same calendar object as the last call (a run's ~350 dates)
        working = last[1]
    else:  # by value (hashing a pydantic model costs more than the rest of a call)
        working = _working_days(calendar)
        _LAST_ASKED = (calendar, working)
    days = working.days
    left = float(seconds)
    k = 0
    while True:
        if k == len(days):
            working.extend()
        begin, available = days[k]
        if left <= available:
            return begin + dt.timedelta(seconds=left)
        left -= available
        k += 1


def working_seconds(calendar: Calendar, when: dt.datetime) -> float:
    """Working seconds from second 0 to ``when``: the inverse of :func:`calendar_datetime`
    for a moment in working time; a moment outside counts up to the last working moment
    before it, a moment before second 0 is 0."""
    moment = first_working_moment(calendar)
    total = 0.0
    day = moment.date()
    while day <= when.date():
        window = working_window(calendar, day)
        if window is not None:
            begin, end = max(window[0], moment), min(window[1], when)
            total += max(0.0, (end - begin).total_seconds())
        day += _DAY
    return total


def working_day_openings(calendar: Calendar, end_s: float) -> list[tuple[float, dt.date]]:
    """Each working day after second 0's day whose opening comes by second ``end_s``, as
    (its simulated second, its date): where a time axis in simulated seconds meets the days."""
    moment = first_working_moment(calendar)
    first = working_window(calendar, moment.date())
    elapsed = (first[1] - moment).total_seconds() if first is not None else 0.0
    day = moment.date() + _DAY
    out: list[tuple[float, dt.date]] = []
    while elapsed <= end_s:
        window = working_window(calendar, day)
        if window is not None:
            out.append((elapsed, day))
            elapsed += (window[1] - window[0]).total_seconds()
        day += _DAY
    return out


def iso(moment: dt.datetime) -> str:
    """``2026-01-12T08:00:01``: to the whole second, as ``schedule.csv`` and the 4D export write
    dates."""
    return moment.isoformat(timespec="seconds")


def describe(calendar: Calendar) -> str:
    """``08:00-16:00 Mon-Fri, 1 holiday``: the working time, in words for charts and logs."""
    days = calendar.working_days
    idx = [WEEKDAYS.index(d) for d in days]
    run = len(idx) > 2 and idx == list(range(idx[0], idx[-1] + 1))
    text = f"{calendar.working_hours} {days[0]}-{days[-1]}" if run else \
        f"{calendar.working_hours} {','.join(days)}"
    n = len(calendar.holidays)
    return text + (f", {n} holiday{'s' if n > 1 else ''}" if n else "")


def calendar_summary(calendar: Calendar, makespan_s: float | None,
                     simulated_s: float | None) -> dict:
    """``summary.json``'s ``calendar``: the calendar used, second 0 (and whether the start was
    moved to it), and the dates of the finish (the makespan; None when not every task ended)
    and of the stop (``simulated_s``)."""
    zero = first_working_moment(calendar)
    return {
        "start": iso(calendar.start), "working_hours": calendar.working_hours,
        "working_days": list(calendar.working_days),
        "holidays": [d.isoformat() for d in calendar.holidays],
        "second_0": iso(zero), "start_moved": zero != calendar.start,
        "finish": iso(calendar_datetime(calendar, makespan_s)) if makespan_s is not None
        else None,
        "stopped": iso(calendar_datetime(calendar, simulated_s)) if simulated_s is not None
        else None,
    }


def finish_dates(calendar: Calendar, makespans_s: dict[str, float | None]) -> dict:
    """Planner's dates of several makespans at once (``{"p80": 33000.0, ...}`` -> ``{"p80":
    "2026-01-21T11:10:00", ...}``, None kept), with the calendar's second 0 and its working
    time in words: ``makespans.json``'s and ``cmdp-evaluate``'s ``calendar`` entries."""
    return {"second_0": iso(first_working_moment(calendar)), "working_time": describe(calendar),
            **{k: iso(calendar_datetime(calendar, s)) if s is not None else None
               for k, s in makespans_s.items()}}
