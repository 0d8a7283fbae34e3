"""The working calendar (``cases.model.Calendar``, ``cmdp_pymunk.workcalendar``): simulated
seconds as dates, worked out by hand, and the calendar's validation (file, entry, fix)."""

from __future__ import annotations

import datetime as dt

import pytest

from cmdp_pymunk.cases.load import (
    CaseError,
    calendar_with,
    case_from_dict,
    load_calendar,
)
from cmdp_pymunk.cases.model import Calendar
from cmdp_pymunk.workcalendar import (
    calendar_datetime,
    calendar_summary,
    describe,
    first_working_moment,
    working_day_openings,
    working_seconds,
)

D = dt.datetime
# Friday 2026-01-09 15:00; days 08:00-16:00 (8 h = 28,800 s), Monday to Friday.
FRIDAY = Calendar(start=D(2026, 1, 9, 15), working_hours="08:00-16:00", working_days="Mon-Fri")
# The same with Monday 2026-01-12 a holiday.
HOLIDAY = Calendar(start=D(2026, 1, 9, 15), working_hours="08:00-16:00",
                   working_days="Mon-Fri", holidays=["2026-01-12"])


@pytest.mark.parametrize("seconds, expected", [
    (0, D(2026, 1, 9, 15)),                # second 0: the start, Fri 15:00 (working time)
    (1800, D(2026, 1, 9, 15, 30)),         # half an hour on
    (3600, D(2026, 1, 9, 16)),             # Friday's last hour used up: Fri 16:00, the closing
    (3601, D(2026, 1, 12, 8, 0, 1)),       # one second more: Sat, Sun off -> Mon 08:00:01
    (3600 + 28800, D(2026, 1, 12, 16)),    # all of Monday: Mon 16:00
    (3600 + 28800 + 60, D(2026, 1, 13, 8, 1)),  # then Tue 08:01
    (3600 + 5 * 28800 + 1, D(2026, 1, 19, 8, 0, 1)),  # Mon-Fri of the next week: Mon 19th
])
def test_seconds_across_a_weekend_by_hand(seconds, expected):
    assert calendar_datetime(FRIDAY, seconds) == expected
    assert working_seconds(FRIDAY, expected) == seconds  # and back


@pytest.mark.parametrize("seconds, expected", [
    (3600, D(2026, 1, 9, 16)),             # Friday is unchanged
    (3601, D(2026, 1, 13, 8, 0, 1)),       # Sat, Sun off, Mon the holiday -> Tue 08:00:01
    (3600 + 28800, D(2026, 1, 13, 16)),    # the first full day worked is Tuesday
    (3600 + 28800 + 0.5, D(2026, 1, 14, 8, 0, 0, 500000)),  # fractions of a second kept
])
def test_seconds_across_a_weekend_and_a_holiday_by_hand(seconds, expected):
    assert calendar_datetime(HOLIDAY, seconds) == expected
    assert working_seconds(HOLIDAY, expected) == seconds


def test_a_start_outside_working_time_moves_to_the_next_working_moment():
    # Saturday 10:00 -> Monday 08:00; Friday 16:00 (the closing) -> Monday 08:00 too;
    # Tuesday 06:30 (before the opening) -> Tuesday 08:00; a holiday Monday -> Tuesday 08:00.
    def zero(start, **kw):
        return first_working_moment(Calendar(start=start, **kw))

    assert zero(D(2026, 1, 10, 10)) == D(2026, 1, 12, 8)
    assert zero(D(2026, 1, 9, 16)) == D(2026, 1, 12, 8)
    assert zero(D(2026, 1, 13, 6, 30)) == D(2026, 1, 13, 8)
    assert zero(D(2026, 1, 12, 9), holidays=[dt.date(2026, 1, 12)]) == D(2026, 1, 13, 8)
    assert zero(dt.date(2026, 1, 12)) == D(2026, 1, 12, 8)  # a date alone: its midnight
    # second 3600 from Sat 10:00 is Mon 09:00: counted from the moved start
    assert calendar_datetime(Calendar(start=D(2026, 1, 10, 10)), 3600) == D(2026, 1, 12, 9)


def test_working_seconds_outside_working_time_count_up_to_the_last_working_moment():
    assert working_seconds(FRIDAY, D(2026, 1, 10, 12)) == 3600   # Saturday: Friday's hour
    assert working_seconds(FRIDAY, D(2026, 1, 12, 7)) == 3600    # Monday before the opening
    assert working_seconds(FRIDAY, D(2026, 1, 1)) == 0           # before second 0


def test_openings_on_the_time_axis_by_hand():
    # Fri 15:00 start: Monday opens at 3600 s, Tuesday at 3600 + 28800 = 32400 s; with the
    # Monday holiday, Tuesday at 3600 and Wednesday at 32400.
    assert working_day_openings(FRIDAY, 40000) == [(3600.0, dt.date(2026, 1, 12)),
                                                   (32400.0, dt.date(2026, 1, 13))]
    assert working_day_openings(HOLIDAY, 32400) == [(3600.0, dt.date(2026, 1, 13)),
                                                    (32400.0, dt.date(2026, 1, 14))]
    assert working_day_openings(FRIDAY, 3599) == []


def test_a_round_the_clock_calendar_is_elapsed_time():
    always = Calendar(start=D(2026, 1, 9, 15), working_hours="00:00-24:00",
                      working_days="Mon-Sun")
    assert calendar_datetime(always, 86400 * 3 + 60) == D(2026, 1, 12, 15, 1)


def test_a_wrapping_range_and_full_names():
    cal = Calendar(start=D(2026, 1, 4, 8), working_days="Sun-Thu")
    assert cal.working_days == ("Mon", "Tue", "Wed", "Thu", "Sun")
    assert Calendar(start=D(2026, 1, 4, 8), working_days=["monday", "Wed"]).working_days == \
        ("Mon", "Wed")
    # Sunday 2026-01-04 is a working day here: its 8 h end at Sun 16:00, then Mon 08:00:01
    assert calendar_datetime(cal, 28800 + 1) == D(2026, 1, 5, 8, 0, 1)


def test_summary_and_description():
    got = calendar_summary(HOLIDAY, 3601.0, 4000.0)
    assert got == {"start": "2026-01-09T15:00:00", "working_hours": "08:00-16:00",
                   "working_days": ["Mon", "Tue", "Wed", "Thu", "Fri"],
                   "holidays": ["2026-01-12"], "second_0": "2026-01-09T15:00:00",
                   "start_moved": False, "finish": "2026-01-13T08:00:01",
                   "stopped": "2026-01-13T08:06:40"}  # 4000 - 3600 = 400 s = 6 min 40 s
    assert describe(HOLIDAY) == "08:00-16:00 Mon-Fri, 1 holiday"
    assert calendar_summary(FRIDAY, None, 0.0)["finish"] is None


# -- validation: the file, the entry, the fix ------------------------------------------------

@pytest.mark.parametrize("entry, value, words", [
    ("working_hours", "17:00-08:00", "ends before it starts"),
    ("working_hours", "08:00-08:00", "ends before it starts"),
    ("working_hours", "8-16", "is not a time range"),
    ("working_hours", "08:00-24:30", "is not a time of day"),
    ("working_days", "Mon-Fry", 'did you mean "Fri"?'),
    ("working_days", [], "no working day"),
    ("holidays", ["2026-13-01"], '"2026-13-01" is not a date'),
    ("holidays", [D(2026, 1, 12, 8)], "a holiday is a whole date"),
    ("start", "2026-01-32T08:00", "is not a date and time"),
    ("start", "2026-01-09T15:00+01:00", "has a UTC offset"),
    ("start", 1767970800, "is not a date and time"),
])
def test_bad_calendars_name_the_file_the_entry_and_the_fix(tiny_case, entry, value, words):
    data = tiny_case.model_dump(mode="json")
    data["calendar"] = {"start": "2026-01-09T15:00", entry: value}
    with pytest.raises(CaseError) as err:
        case_from_dict(data, "floor.toml")
    text = str(err.value)
    assert f"floor.toml: calendar: {entry}: " in text and words in text and "; fix: " in text


def test_a_calendar_file_and_command_line_options(tmp_path):
    path = tmp_path / "site.toml"
    path.write_text('[calendar]\nstart = 2026-01-09T15:00:00\nworking_hours = "07:00-15:30"\n'
                    'holidays = [2026-01-12]\n', encoding="utf-8")
    cal = load_calendar(path)
    assert (cal.opening_s, cal.closing_s) == (7 * 3600, 15 * 3600 + 1800)
    labels = {"start": "--start", "working_hours": "--working-hours"}
    moved = calendar_with(cal, {"start": "2026-01-05T08:00", "working_hours": None}, "cli",
                          labels)
    assert moved.start == D(2026, 1, 5, 8) and moved.working_hours == "07:00-15:30"
    with pytest.raises(CaseError, match=r"cli: --start: required field missing .*"
                                        r"fix: give --start 2026-01-05T08:00"):
        calendar_with(None, {"working_hours": "08:00-12:00"}, "cli", labels)
    with pytest.raises(CaseError, match=r'cli: --working-hours: "12:00-08:00" ends before'):
        calendar_with(cal, {"working_hours": "12:00-08:00"}, "cli", labels)
    path.write_text("[calendar]\nstrat = 2026-01-09T15:00:00\n", encoding="utf-8")
    with pytest.raises(CaseError) as err:
        load_calendar(path)
    assert 'site.toml: calendar: strat: unknown field; fix: did you mean "start"?' in str(err.value)
    path.write_text("start = 2026-01-09T15:00:00\n", encoding="utf-8")
    with pytest.raises(CaseError, match=r"site.toml: no \[calendar\] table; fix"):
        load_calendar(path)


def test_a_case_with_a_calendar_round_trips_and_one_without_dumps_as_before(tiny_case):
    assert "calendar" not in tiny_case.model_dump(mode="json")
    data = tiny_case.model_dump(mode="json")
    data["calendar"] = {"start": "2026-01-09T15:00:00", "working_days": "Mon-Fri",
                        "holidays": ["2026-01-12"]}
    case = case_from_dict(data)
    assert case.model_dump(mode="json")["calendar"] == {
        "start": "2026-01-09T15:00:00", "working_hours": "08:00-16:00",
        "working_days": ["Mon", "Tue", "Wed", "Thu", "Fri"], "holidays": ["2026-01-12"]}
    assert case_from_dict(case.model_dump(mode="json")) == case


def test_finish_dates_of_several_makespans_by_hand():
    from cmdp_pymunk.workcalendar import finish_dates

    # 3600 s ends Friday at 16:00; 3600 + 60 s is Tuesday 08:01 (Monday the 12th a holiday)
    got = finish_dates(HOLIDAY, {"p50": 3600.0, "p80": 3660.0, "max": None})
    assert got == {"second_0": "2026-01-09T15:00:00",
                   "working_time": "08:00-16:00 Mon-Fri, 1 holiday",
                   "p50": "2026-01-09T16:00:00", "p80": "2026-01-13T08:01:00", "max": None}


def test_makespans_files_carry_the_finish_dates(tmp_path):
    """``cmdp-simulate --episodes N``'s makespans.csv and makespans.json with a calendar: the
    dates of three made-up floors (1800 s, 3660 s, unfinished) by hand."""
    import json

    from training.runs.makespans import write_makespans

    rows = [{"seed": s, "makespan_s": m, "makespan_over_lower_bound": None,
             "tasks_finished": 3, "all_finished": m is not None, "reach_rate": 1.0,
             "lower_bound": {"lower_bound_s": 1000.0}}
            for s, m in ((0, 1800.0), (1, 3660.0), (2, None))]
    stats = write_makespans(tmp_path, rows, HOLIDAY)
    lines = (tmp_path / "makespans.csv").read_text().splitlines()
    assert lines[0].endswith(",finish")
    assert [line.rsplit(",", 1)[1] for line in lines[1:]] == \
        ["2026-01-09T15:30:00", "2026-01-13T08:01:00", ""]
    saved = json.loads((tmp_path / "makespans.json").read_text())
    assert saved["calendar"] == stats["calendar"]
    # mean of the two finished floors 2730 s: Friday 15:45:30; min/max their own dates
    assert (saved["calendar"]["mean"], saved["calendar"]["min"], saved["calendar"]["max"]) == \
        ("2026-01-09T15:45:30", "2026-01-09T15:30:00", "2026-01-13T08:01:00")
    write_makespans(tmp_path, rows)  # without a calendar: no dates
    assert json.loads((tmp_path / "makespans.json").read_text())["calendar"] is None
    assert not (tmp_path / "makespans.csv").read_text().splitlines()[0].endswith(",finish")
