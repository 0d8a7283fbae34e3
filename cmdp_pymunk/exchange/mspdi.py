"""The simulated schedule as MS Project XML (MSPDI), the file planners open in MS Project,
ProjectLibre, GanttProject or Primavera P6 (which imports it), or read with MPXJ.

What it holds (``cmdp-simulate`` writes it as ``schedule.xml`` beside ``schedule.csv``):

- **Tasks**: one per task of the case, in order of start as ``schedule.csv`` lists them (the
  tasks that never started last); ``UID`` is the task's place in the case (so one task has one
  UID on every seed), ``Name`` its id, ``Start``/``Finish`` the dates of its simulated start
  and finish, ``Duration`` (ISO 8601, ``PT2H5M0S``) the working time between them, pauses
  included (its pauses are counted in ``Notes``). Custom columns: Text1 the component, Text2
  the task type's name, Text3 the crew. Each task is constrained to start no earlier than its
  simulated start (``ConstraintType`` 4): the precedences alone do not know that crews and the
  crane are scarce, so a tool that reschedules would otherwise pull tasks earlier than the
  simulation could do them.
- **PredecessorLink**: the case's precedences, finish-to-start (``Type`` 1), no lag.
- **Resources**: one per crew (``Type`` 1, work), its type in ``Group`` and ``Initials``;
  **Assignments**: each started task to the crew that started it, 100 %, its work the task's
  duration.
- **Calendar**: the working calendar (``workcalendar``): its working days with their hours,
  its holidays as exceptions. Simulated time is working time, so a task's duration is its
  simulated seconds.

A simulation is a forecast, not progress: no task is marked complete. A run that stalled or
reached its time limit still gets a file: a started task that did not finish ends where the
run stopped, a task that never started is 0 long at that moment, and ``Notes`` says which.

Without a working calendar the dates come from :data:`DEFAULT_START` (Monday 2026-01-05
08:00) with the calendar ``--start`` alone gives (08:00-16:00, Mon-Fri). Times are rounded
to whole seconds. Written with the standard library (``xml.etree.ElementTree``); the same log
and case give the same bytes (no time stamp of writing).
"""

from __future__ import annotations

import datetime as dt
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

from ..cases.model import WEEKDAYS, Calendar
from ..events import Event, write_atomic
from ..schedule import log_end_s, paused_at_end, task_bars
from ..workcalendar import calendar_datetime, first_working_moment

NAMESPACE = "http://schemas.microsoft.com/project"
DEFAULT_START = dt.datetime(2026, 1, 5, 8, 0)  # a Monday's opening; docs/simulating.md
SAVE_VERSION = "14"  # MS Project 2010's MSPDI, which every later version and MPXJ read
CALENDAR_UID = 1
FINISH_TO_START = 1  # PredecessorLink Type
START_NO_EARLIER_THAN = 4  # ConstraintType
WORK_RESOURCE = 1  # Resource Type
DURATION_FORMAT_HOURS = 5  # how MS Project shows a duration: hours
LAG_FORMAT_DAYS = 7
# MSPDI's DayType: 1 Sunday ... 7 Saturday.
DAY_TYPE = {day: (k + 1) % 7 + 1 for k, day in enumerate(WEEKDAYS)}
# Task fields Text1-Text3 and the names they show under in a planner's tool.
TEXT_FIELDS = (("188743731", "Text1", "Component"), ("188743734", "Text2", "Task type"),
               ("188743737", "Text3", "Crew"))


_DECLARATION = "<?xml version='1.0' encoding='UTF-8'?>\n"  # as ElementTree writes it


def default_calendar() -> Calendar:
    """The calendar of a run without one: :data:`DEFAULT_START`, 08:00-16:00, Mon-Fri."""
    return Calendar(start=DEFAULT_START)


def iso_duration(seconds: int) -> str:
    """Whole seconds as MSPDI writes a duration: 9000 -> ``PT2H30M0S`` (ISO 8601)."""
    if seconds < 0:
        raise ValueError(f"a duration is at least 0 s, got {seconds}")
    return f"PT{seconds // 3600}H{seconds % 3600 // 60}M{seconds % 60}S"


def _when(moment: dt.datetime) -> str:
    return moment.isoformat(timespec="seconds")


def start_datetime(calendar: Calendar, seconds: int) -> dt.datetime:
    """The date a task starting at simulated second ``seconds`` starts: as
    ``workcalendar.calendar_datetime``, but a start at a day's closing is the next working
    day's opening (where a planner's tool puts it; a finish keeps the closing)."""
    # Half a second later lands after the closing, in the next opening, whose own time is
    # then half a second too late; whole seconds otherwise come back unchanged.
    return calendar_datetime(calendar, seconds + 0.5) - dt.timedelta(seconds=0.5)


def _add(parent: ET.Element, tag: str, text: object = None) -> ET.Element:
    element = ET.SubElement(parent, tag)
    if text is not None:
        element.text = str(text)
    return element


def _calendar(parent: ET.Element, calendar: Calendar, name: str) -> None:
    """The working calendar as MSPDI's base calendar: seven WeekDays, holidays as
    Exceptions."""
    element = _add(_add(parent, "Calendars"), "Calendar")
    _add(element, "UID", CALENDAR_UID)
    _add(element, "Name", name)
    _add(element, "IsBaseCalendar", 1)
    _add(element, "BaseCalendarUID", -1)
    opening = dt.timedelta(seconds=calendar.opening_s)
    closing = dt.timedelta(seconds=calendar.closing_s)
    week = _add(element, "WeekDays")
    for day in sorted(WEEKDAYS, key=DAY_TYPE.get):
        weekday = _add(week, "WeekDay")
        _add(weekday, "DayType", DAY_TYPE[day])
        working = day in calendar.working_days
        _add(weekday, "DayWorking", int(working))
        if working:
            times = _add(_add(weekday, "WorkingTimes"), "WorkingTime")
            _add(times, "FromTime", _clock(opening))
            _add(times, "ToTime", _clock(closing))
    if calendar.holidays:
        exceptions = _add(element, "Exceptions")
        for day in calendar.holidays:
            exception = _add(exceptions, "Exception")
            _add(exception, "EnteredByOccurrences", 0)
            period = _add(exception, "TimePeriod")
            _add(period, "FromDate", _when(dt.datetime.combine(day, dt.time())))
            _add(period, "ToDate", _when(dt.datetime.combine(day, dt.time(23, 59))))
            _add(exception, "Occurrences", 1)
            _add(exception, "Name", "holiday")
            _add(exception, "Type", 1)  # a single day (not a recurring one)
            _add(exception, "DayWorking", 0)


def _clock(since_midnight: dt.timedelta) -> str:
    """``08:00:00``; a closing at 24:00 is written ``00:00:00``, as MS Project does."""
    seconds = int(since_midnight.total_seconds()) % 86400
    return f"{seconds // 3600:02d}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"


def schedule_mspdi(events: Sequence[Event], case, end_s: float | None = None,
                   calendar: Calendar | None = None) -> bytes:
    """The run's schedule as an MSPDI document (the module doc), UTF-8 with its declaration.

    Args:
        events: the run's event log.
        case: the case the run was made with (its tasks, precedences, crews).
        end_s: when the run stopped (``summary.json``'s ``simulated_s``); default the log's
            last event. Only a run that did not finish uses it.
        calendar: the working calendar; default the case's, else :func:`default_calendar`.
    """
    calendar = calendar or getattr(case, "calendar", None) or default_calendar()
    stop = round(log_end_s(events) if end_s is None else max(end_s, log_end_s(events)))
    bars = {b.task: b for b in task_bars(events, stop)}
    paused_since = paused_at_end(events)
    uid = {t.id: k for k, t in enumerate(case.tasks, start=1)}
    crew_uid = {c.id: k for k, c in enumerate(case.crews, start=1)}
    order = sorted(bars.values(), key=lambda b: b.start_s)  # as schedule.csv
    rows = [b.task for b in order if b.task in uid] + [t.id for t in case.tasks
                                                       if t.id not in bars]
    spans = {}  # task -> (start s, finish s, notes), whole seconds
    for task in rows:
        bar = bars.get(task)
        if bar is None:
            spans[task] = (stop, stop, "not started when the simulation stopped")
            continue
        start, finish = round(bar.start_s), round(bar.end_s)
        pauses = [b - a for a, b in bar.pauses]
        if not bar.finished and task in paused_since:  # paused when the run stopped
            pauses.append(stop - paused_since[task])
        notes = "" if bar.finished else "not finished when the simulation stopped"
        if pauses:
            notes = "; ".join(filter(None, [
                f"paused {len(pauses)} time{'s' if len(pauses) > 1 else ''} "
                f"({sum(pauses):,.0f} s)", notes]))
        spans[task] = (start, finish, notes)

    project = ET.Element("Project", xmlns=NAMESPACE)
    zero = first_working_moment(calendar)
    last = max((f for _, f, _ in spans.values()), default=0)
    name = case.case.name
    _add(project, "SaveVersion", SAVE_VERSION)
    _add(project, "Name", f"{name}.xml")
    _add(project, "Title", f"{name}: simulated schedule (cmdp-simulate)")
    _add(project, "ScheduleFromStart", 1)
    _add(project, "StartDate", _when(zero))
    _add(project, "FinishDate", _when(calendar_datetime(calendar, last)))
    _add(project, "CalendarUID", CALENDAR_UID)
    _add(project, "DefaultStartTime", _clock(dt.timedelta(seconds=calendar.opening_s)))
    _add(project, "DefaultFinishTime", _clock(dt.timedelta(seconds=calendar.closing_s)))
    minutes_per_day = (calendar.closing_s - calendar.opening_s) // 60
    _add(project, "MinutesPerDay", minutes_per_day)
    _add(project, "MinutesPerWeek", minutes_per_day * len(calendar.working_days))
    _add(project, "DaysPerMonth", 20)
    _add(project, "DurationFormat", DURATION_FORMAT_HOURS)
    attributes = _add(project, "ExtendedAttributes")
    for field_id, field_name, alias in TEXT_FIELDS:
        attribute = _add(attributes, "ExtendedAttribute")
        _add(attribute, "FieldID", field_id)
        _add(attribute, "FieldName", field_name)
        _add(attribute, "Alias", alias)
    _calendar(project, calendar, f"{name} working time")

    spec = {t.id: t for t in case.tasks}
    tasks = _add(project, "Tasks")
    for row, task_id in enumerate(rows, start=1):
        task, bar = spec[task_id], bars.get(task_id)
        start, finish, notes = spans[task_id]
        began = start_datetime(calendar, start)
        element = _add(tasks, "Task")
        _add(element, "UID", uid[task_id])
        _add(element, "ID", row)
        _add(element, "Name", task_id)
        _add(element, "Type", 0)  # fixed units: one crew, the duration is the work
        _add(element, "IsNull", 0)
        _add(element, "OutlineNumber", row)
        _add(element, "OutlineLevel", 1)
        _add(element, "Priority", 500)
        _add(element, "Start", _when(began))
        _add(element, "Finish", _when(calendar_datetime(calendar, finish)))
        _add(element, "Duration", iso_duration(finish - start))
        _add(element, "DurationFormat", DURATION_FORMAT_HOURS)
        _add(element, "Milestone", 0)
        _add(element, "Summary", 0)
        _add(element, "PercentComplete", 0)
        _add(element, "ConstraintType", START_NO_EARLIER_THAN)
        _add(element, "ConstraintDate", _when(began))
        if notes:
            _add(element, "Notes", notes)
        for predecessor in task.predecessors:
            link = _add(element, "PredecessorLink")
            _add(link, "PredecessorUID", uid[predecessor])
            _add(link, "Type", FINISH_TO_START)
            _add(link, "CrossProject", 0)
            _add(link, "LinkLag", 0)
            _add(link, "LagFormat", LAG_FORMAT_DAYS)
        type_name = case.task_types[task.type].name if task.type in case.task_types \
            else task.type
        for (field_id, _, _), value in zip(TEXT_FIELDS, (task.component, type_name,
                                                          bar.crew if bar else ""),
                                           strict=True):
            if value:
                attribute = _add(element, "ExtendedAttribute")
                _add(attribute, "FieldID", field_id)
                _add(attribute, "Value", value)

    resources = _add(project, "Resources")
    for crew in case.crews:
        element = _add(resources, "Resource")
        _add(element, "UID", crew_uid[crew.id])
        _add(element, "ID", crew_uid[crew.id])
        _add(element, "Name", crew.id)
        _add(element, "Type", WORK_RESOURCE)
        _add(element, "IsNull", 0)
        _add(element, "Initials", crew.type)
        crew_type = case.crew_types.get(crew.type)
        _add(element, "Group", crew_type.name if crew_type is not None else crew.type)
        _add(element, "MaxUnits", "1.00")

    assignments = _add(project, "Assignments")
    started = [t for t in rows if t in bars and bars[t].crew in crew_uid]
    for k, task_id in enumerate(started, start=1):
        start, finish, _ = spans[task_id]
        element = _add(assignments, "Assignment")
        _add(element, "UID", k)
        _add(element, "TaskUID", uid[task_id])
        _add(element, "ResourceUID", crew_uid[bars[task_id].crew])
        _add(element, "Finish", _when(calendar_datetime(calendar, finish)))
        _add(element, "Start", _when(start_datetime(calendar, start)))
        _add(element, "Units", 1)
        _add(element, "Work", iso_duration(finish - start))

    ET.indent(project)
    # serialised to a str and encoded once: ElementTree's own UTF-8 writer resets a codec on
    # each of its ~19,000 writes (four fifths of the file's time); the bytes are the same
    return (_DECLARATION + ET.tostring(project, encoding="unicode") + "\n").encode("utf-8")


def write_mspdi(path: str | Path, events: Sequence[Event], case, end_s: float | None = None,
                calendar: Calendar | None = None) -> Path:
    """:func:`schedule_mspdi` written to ``path`` whole or not at all (a temporary file, then
    a rename); returns the path."""
    path = Path(path)
    write_atomic(path, schedule_mspdi(events, case, end_s, calendar))
    return path
