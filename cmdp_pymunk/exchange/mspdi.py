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
to whole seconds. The same log and case give the same bytes (no time stamp of writing). The
text is written directly (:class:`XmlText`), byte for byte as ``xml.etree.ElementTree`` with
``ET.indent`` writes the same elements (:class:`ElementTreeXml`, the reference the tests compare
it with): the whole file in 6.5 ms a floor instead of 17.7 (built-in case, CPU under load),
and ``cmdp-simulate --episodes 1000`` writes one file a seed.
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


class XmlText:
    """Writes an element tree as indented text, the bytes ``ET.indent`` and ``ET.tostring``
    give for the same elements (two spaces a level, ``<Tag />`` for an element without text
    or children, ``&``, ``<`` and ``>`` escaped in text) without building the tree: one
    schedule is ~3,800 elements, and ElementTree's tree, indentation and serialisation were
    about two thirds of the file's time."""

    def __init__(self, root: str, attributes: dict[str, str]) -> None:
        attrs = "".join(f' {k}="{_escape_attribute(v)}"' for k, v in attributes.items())
        self._lines = [f"<{root}{attrs}>"]
        self._open = [(root, 0)]  # the elements not yet closed: tag, line of its opening

    def open(self, tag: str) -> XmlText:
        """Starts a child of the innermost open element; :meth:`close` ends it."""
        self._open.append((tag, len(self._lines)))
        self._lines.append(f"{'  ' * (len(self._open) - 1)}<{tag}>")
        return self

    def leaf(self, tag: str, text: object = None) -> None:
        """A child without children: ``<Tag>text</Tag>``, or ``<Tag />`` without text."""
        text = "" if text is None else str(text)
        indent = "  " * len(self._open)
        if not text:
            self._lines.append(f"{indent}<{tag} />")
            return
        if "&" in text or "<" in text or ">" in text:
            text = _escape_text(text)
        self._lines.append(f"{indent}<{tag}>{text}</{tag}>")

    def close(self) -> None:
        """Ends the innermost open element (``<Tag />`` when nothing went into it)."""
        tag, line = self._open.pop()
        if line == len(self._lines) - 1:  # no child: ElementTree's empty element
            self._lines[line] = self._lines[line][:-1] + " />"
        else:
            self._lines.append(f"{'  ' * len(self._open)}</{tag}>")

    def document(self) -> bytes:
        """The whole document, UTF-8 with ElementTree's declaration; closes what is open."""
        while self._open:
            self.close()
        return (_DECLARATION + "\n".join(self._lines) + "\n").encode("utf-8")


class ElementTreeXml:
    """The same calls as :class:`XmlText`, made on an ``xml.etree.ElementTree`` tree and
    serialised by it: the reference :class:`XmlText`'s bytes are tested against."""

    def __init__(self, root: str, attributes: dict[str, str]) -> None:
        self._stack = [ET.Element(root, attributes)]

    def open(self, tag: str) -> ElementTreeXml:
        self._stack.append(ET.SubElement(self._stack[-1], tag))
        return self

    def leaf(self, tag: str, text: object = None) -> None:
        element = ET.SubElement(self._stack[-1], tag)
        if text is not None:
            element.text = str(text)

    def close(self) -> None:
        self._stack.pop()

    def document(self) -> bytes:
        root = self._stack[0]
        ET.indent(root)
        return (_DECLARATION + ET.tostring(root, encoding="unicode") + "\n").encode("utf-8")


def _escape_text(text: str) -> str:
    """Text escaped as ElementTree escapes it (``&``, ``<``, ``>``)."""
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _escape_attribute(text: str) -> str:
    """An attribute value escaped as ElementTree escapes it."""
    text = _escape_text(text).replace('"', "&quot;")
    return text.replace("\r", "&#13;").replace("\n", "&#10;").replace("\t", "&#09;")


def _calendar(x: XmlText, calendar: Calendar, name: str) -> None:
    """The working calendar as MSPDI's base calendar: seven WeekDays, holidays as
    Exceptions."""
    x.open("Calendars").open("Calendar")
    x.leaf("UID", CALENDAR_UID)
    x.leaf("Name", name)
    x.leaf("IsBaseCalendar", 1)
    x.leaf("BaseCalendarUID", -1)
    opening = _clock(dt.timedelta(seconds=calendar.opening_s))
    closing = _clock(dt.timedelta(seconds=calendar.closing_s))
    x.open("WeekDays")
    for day in sorted(WEEKDAYS, key=DAY_TYPE.get):
        x.open("WeekDay")
        x.leaf("DayType", DAY_TYPE[day])
        working = day in calendar.working_days
        x.leaf("DayWorking", int(working))
        if working:
            x.open("WorkingTimes").open("WorkingTime")
            x.leaf("FromTime", opening)
            x.leaf("ToTime", closing)
            x.close()
            x.close()
        x.close()
    x.close()  # WeekDays
    if calendar.holidays:
        x.open("Exceptions")
        for day in calendar.holidays:
            x.open("Exception")
            x.leaf("EnteredByOccurrences", 0)
            x.open("TimePeriod")
            x.leaf("FromDate", _when(dt.datetime.combine(day, dt.time())))
            x.leaf("ToDate", _when(dt.datetime.combine(day, dt.time(23, 59))))
            x.close()
            x.leaf("Occurrences", 1)
            x.leaf("Name", "holiday")
            x.leaf("Type", 1)  # a single day (not a recurring one)
            x.leaf("DayWorking", 0)
            x.close()
        x.close()
    x.close()  # Calendar
    x.close()  # Calendars


def _clock(since_midnight: dt.timedelta) -> str:
    """``08:00:00``; a closing at 24:00 is written ``00:00:00``, as MS Project does."""
    seconds = int(since_midnight.total_seconds()) % 86400
    return f"{seconds // 3600:02d}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"


def schedule_mspdi(events: Sequence[Event], case, end_s: float | None = None,
                   calendar: Calendar | None = None, writer: type = XmlText) -> bytes:
    """The run's schedule as an MSPDI document (the module doc), UTF-8 with its declaration.

    Args:
        events: the run's event log.
        case: the case the run was made with (its tasks, precedences, crews).
        end_s: when the run stopped (``summary.json``'s ``simulated_s``); default the log's
            last event. Only a run that did not finish uses it.
        calendar: the working calendar; default the case's, else :func:`default_calendar`.
        writer: what writes the XML: :class:`XmlText`, or :class:`ElementTreeXml` (the same
            bytes, slower; the tests' reference).
    """
    calendar = calendar or getattr(case, "calendar", None) or default_calendar()
    stop = round(log_end_s(events) if end_s is None else max(end_s, log_end_s(events)))
    bars = {b.task: b for b in task_bars(events, stop)}
    uid = {t.id: k for k, t in enumerate(case.tasks, start=1)}
    crew_uid = {c.id: k for k, c in enumerate(case.crews, start=1)}
    order = sorted(bars.values(), key=lambda b: b.start_s)  # as schedule.csv
    rows = [b.task for b in order if b.task in uid] + [t.id for t in case.tasks
                                                       if t.id not in bars]
    spans = _task_spans(events, rows, bars, stop)
    x = writer("Project", {"xmlns": NAMESPACE})
    _project(x, case, calendar, spans)
    _tasks(x, case, calendar, rows, spans, bars, uid)
    _resources(x, case, crew_uid)
    _assignments(x, calendar, rows, spans, bars, uid, crew_uid)
    return x.document()


def _task_spans(events: Sequence[Event], rows: list[str], bars: dict, stop: int) -> dict:
    """Each task's (start s, finish s, notes) in whole seconds: its bar, or the stop for a
    task not started; the notes say what was left undone and the pauses."""
    paused_since = paused_at_end(events)
    spans = {}
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
    return spans


def _project(x, case, calendar: Calendar, spans: dict) -> None:
    """The project's own fields, the task fields' aliases and the working calendar."""
    zero = first_working_moment(calendar)
    last = max((f for _, f, _ in spans.values()), default=0)
    name = case.case.name
    x.leaf("SaveVersion", SAVE_VERSION)
    x.leaf("Name", f"{name}.xml")
    x.leaf("Title", f"{name}: simulated schedule (cmdp-simulate)")
    x.leaf("ScheduleFromStart", 1)
    x.leaf("StartDate", _when(zero))
    x.leaf("FinishDate", _when(calendar_datetime(calendar, last)))
    x.leaf("CalendarUID", CALENDAR_UID)
    x.leaf("DefaultStartTime", _clock(dt.timedelta(seconds=calendar.opening_s)))
    x.leaf("DefaultFinishTime", _clock(dt.timedelta(seconds=calendar.closing_s)))
    minutes_per_day = (calendar.closing_s - calendar.opening_s) // 60
    x.leaf("MinutesPerDay", minutes_per_day)
    x.leaf("MinutesPerWeek", minutes_per_day * len(calendar.working_days))
    x.leaf("DaysPerMonth", 20)
    x.leaf("DurationFormat", DURATION_FORMAT_HOURS)
    x.open("ExtendedAttributes")
    for field_id, field_name, alias in TEXT_FIELDS:
        x.open("ExtendedAttribute")
        x.leaf("FieldID", field_id)
        x.leaf("FieldName", field_name)
        x.leaf("Alias", alias)
        x.close()
    x.close()
    _calendar(x, calendar, f"{name} working time")


def _tasks(x, case, calendar: Calendar, rows: list[str], spans: dict, bars: dict,
           uid: dict) -> None:
    """One ``Task`` a row: its dates, notes, predecessors and text fields."""
    spec = {t.id: t for t in case.tasks}
    x.open("Tasks")
    for row, task_id in enumerate(rows, start=1):
        task, bar = spec[task_id], bars.get(task_id)
        start, finish, notes = spans[task_id]
        began = _when(start_datetime(calendar, start))
        x.open("Task")
        x.leaf("UID", uid[task_id])
        x.leaf("ID", row)
        x.leaf("Name", task_id)
        x.leaf("Type", 0)  # fixed units: one crew, the duration is the work
        x.leaf("IsNull", 0)
        x.leaf("OutlineNumber", row)
        x.leaf("OutlineLevel", 1)
        x.leaf("Priority", 500)
        x.leaf("Start", began)
        x.leaf("Finish", _when(calendar_datetime(calendar, finish)))
        x.leaf("Duration", iso_duration(finish - start))
        x.leaf("DurationFormat", DURATION_FORMAT_HOURS)
        x.leaf("Milestone", 0)
        x.leaf("Summary", 0)
        x.leaf("PercentComplete", 0)
        x.leaf("ConstraintType", START_NO_EARLIER_THAN)
        x.leaf("ConstraintDate", began)
        if notes:
            x.leaf("Notes", notes)
        for predecessor in task.predecessors:
            x.open("PredecessorLink")
            x.leaf("PredecessorUID", uid[predecessor])
            x.leaf("Type", FINISH_TO_START)
            x.leaf("CrossProject", 0)
            x.leaf("LinkLag", 0)
            x.leaf("LagFormat", LAG_FORMAT_DAYS)
            x.close()
        type_name = case.task_types[task.type].name if task.type in case.task_types \
            else task.type
        for (field_id, _, _), value in zip(TEXT_FIELDS, (task.component, type_name,
                                                          bar.crew if bar else ""),
                                           strict=True):
            if value:
                x.open("ExtendedAttribute")
                x.leaf("FieldID", field_id)
                x.leaf("Value", value)
                x.close()
        x.close()  # Task
    x.close()  # Tasks


def _resources(x, case, crew_uid: dict) -> None:
    """One work ``Resource`` a crew."""
    x.open("Resources")
    for crew in case.crews:
        x.open("Resource")
        x.leaf("UID", crew_uid[crew.id])
        x.leaf("ID", crew_uid[crew.id])
        x.leaf("Name", crew.id)
        x.leaf("Type", WORK_RESOURCE)
        x.leaf("IsNull", 0)
        x.leaf("Initials", crew.type)
        crew_type = case.crew_types.get(crew.type)
        x.leaf("Group", crew_type.name if crew_type is not None else crew.type)
        x.leaf("MaxUnits", "1.00")
        x.close()
    x.close()


def _assignments(x, calendar: Calendar, rows: list[str], spans: dict, bars: dict, uid: dict,
                 crew_uid: dict) -> None:
    """One ``Assignment`` a started task: its crew, its dates, its work."""
    x.open("Assignments")
    started = [t for t in rows if t in bars and bars[t].crew in crew_uid]
    for k, task_id in enumerate(started, start=1):
        start, finish, _ = spans[task_id]
        x.open("Assignment")
        x.leaf("UID", k)
        x.leaf("TaskUID", uid[task_id])
        x.leaf("ResourceUID", crew_uid[bars[task_id].crew])
        x.leaf("Finish", _when(calendar_datetime(calendar, finish)))
        x.leaf("Start", _when(start_datetime(calendar, start)))
        x.leaf("Units", 1)
        x.leaf("Work", iso_duration(finish - start))
        x.close()
    x.close()


def write_mspdi(path: str | Path, events: Sequence[Event], case, end_s: float | None = None,
                calendar: Calendar | None = None) -> Path:
    """:func:`schedule_mspdi` written to ``path`` whole or not at all (a temporary file, then
    a rename); returns the path."""
    path = Path(path)
    write_atomic(path, schedule_mspdi(events, case, end_s, calendar))
    return path
