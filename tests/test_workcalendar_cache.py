"""``workcalendar.calendar_datetime`` keeps each calendar's working days once found: it gives
the moments of the plain day-by-day walk (written here again, as the module had it), whatever
order the seconds are asked in, and a calendar equal by value shares them."""

from __future__ import annotations

import datetime as dt

from cmdp_pymunk import workcalendar
from cmdp_pymunk.cases.model import Calendar

# Second 0 Fri 2026-01-09 15:55 (5 min before the closing); Mon 12th and Wed 14th holidays.
CALENDAR = Calendar(start="2026-01-09T15:55", holidays=["2026-01-12", "2026-01-14"])


def walked(calendar: Calendar, seconds: float) -> dt.datetime:
    """The module's rule walked day by day from second 0, nothing kept."""
    day, moment = calendar.start.date(), None
    while moment is None:
        window = workcalendar.working_window(calendar, day)
        if window is not None and calendar.start < window[1]:
            moment = max(calendar.start, window[0])
        day += dt.timedelta(days=1)
    left, day = float(seconds), moment.date()
    while True:
        window = workcalendar.working_window(calendar, day)
        if window is not None:
            begin = max(window[0], moment)
            available = (window[1] - begin).total_seconds()
            if left <= available:
                return begin + dt.timedelta(seconds=left)
            left -= available
        day += dt.timedelta(days=1)


def test_kept_days_give_the_walks_moments_in_any_order():
    # the closings (300, 300 + 28800, ...), a second either side, fractions, and far out
    # first (the kept days grow to there), then near again
    seconds = [10 * 86400.25, 0, 299.5, 300, 300.5, 301, 29100, 29100.25, 57900, 1e6 + 0.125]
    calendar = Calendar(start="2026-01-09T15:55", holidays=["2026-01-12", "2026-01-14"])
    for s in seconds:
        assert workcalendar.calendar_datetime(calendar, s) == walked(calendar, s), s
    # by hand: 300 s is Friday's closing; 301 s is Tue 13th 08:00:01 (Mon is a holiday); a
    # whole day later Thu 15th (Wed is a holiday too)
    assert workcalendar.calendar_datetime(CALENDAR, 300) == dt.datetime(2026, 1, 9, 16)
    assert workcalendar.calendar_datetime(CALENDAR, 301) == dt.datetime(2026, 1, 13, 8, 0, 1)
    assert workcalendar.calendar_datetime(CALENDAR, 301 + 28800) == \
        dt.datetime(2026, 1, 15, 8, 0, 1)


def test_a_start_off_working_time_and_a_calendar_changed_by_value():
    """Second 0 moves to the next opening; a calendar with other hours is not served the first
    one's days (the cache is keyed by the calendar's value)."""
    sunday = Calendar(start="2026-01-11T12:00")
    assert workcalendar.first_working_moment(sunday) == dt.datetime(2026, 1, 12, 8)
    assert workcalendar.calendar_datetime(sunday, 3600) == dt.datetime(2026, 1, 12, 9)
    later = sunday.model_copy(update={"working_hours": "09:00-17:00"})
    assert workcalendar.calendar_datetime(later, 3600) == dt.datetime(2026, 1, 12, 10)
    assert workcalendar.calendar_datetime(Calendar(start="2026-01-11T12:00"), 3600) == \
        dt.datetime(2026, 1, 12, 9)
