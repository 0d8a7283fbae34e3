"""The schedule as MS Project XML (``cmdp_pymunk.exchange.mspdi``): worked out by hand from
the hand-made log of ``conftest.RUN`` on the tiny case, and read back by MPXJ, a reader
nobody here wrote, from a whole ``cmdp-simulate`` run."""

from __future__ import annotations

import datetime as dt
import shutil
import xml.etree.ElementTree as ET

import pytest
from conftest import RUN, make_events

from cmdp_pymunk.cases.model import Calendar
from cmdp_pymunk.exchange import mspdi

NS = {"p": mspdi.NAMESPACE}
# Second 0 is Fri 2026-01-09 15:55; days 08:00-16:00 Mon-Fri; Mon 12th a holiday. So second s
# <= 300 is Fri 15:55 + s, and a later one (within a day) Tue 13th 08:00 + (s - 300).
CALENDAR = Calendar(start="2026-01-09T15:55", holidays=["2026-01-12"])


def by_hand(s: float) -> str:
    at = dt.datetime(2026, 1, 9, 15, 55) + dt.timedelta(seconds=s) if s <= 300 else \
        dt.datetime(2026, 1, 13, 8) + dt.timedelta(seconds=s - 300)
    return at.isoformat(timespec="seconds")


def parsed(text: bytes) -> ET.Element:
    root = ET.fromstring(text)
    assert root.tag == f"{{{mspdi.NAMESPACE}}}Project"
    return root


def tasks_of(root: ET.Element) -> dict[str, ET.Element]:
    return {t.findtext("p:Name", namespaces=NS): t for t in root.findall("p:Tasks/p:Task", NS)}


def test_iso_durations_by_hand():
    assert mspdi.iso_duration(0) == "PT0H0M0S"
    assert mspdi.iso_duration(130) == "PT0H2M10S"
    assert mspdi.iso_duration(9000) == "PT2H30M0S"
    assert mspdi.iso_duration(100000) == "PT27H46M40S"  # hours are not folded into days
    with pytest.raises(ValueError, match="at least 0"):
        mspdi.iso_duration(-1)


def test_a_start_at_the_closing_is_the_next_opening_a_finish_stays():
    # second 300 is Friday's closing: a finish then is Fri 16:00, a start Tue 08:00 (Mon off)
    assert mspdi.start_datetime(CALENDAR, 300) == dt.datetime(2026, 1, 13, 8)
    assert mspdi.start_datetime(CALENDAR, 299) == dt.datetime(2026, 1, 9, 15, 59, 59)
    assert mspdi.start_datetime(CALENDAR, 370) == dt.datetime(2026, 1, 13, 8, 1, 10)


def test_the_hand_made_run_as_mspdi(tiny_case):
    """conftest.RUN: X-A 10-130 (X-1), X-B 160-280 (X-1), K-A 160-300 (K-1, after X-A), M-C
    370-500 (M-1, after K-A, paused 400-440). Rows by start, a tie in log order (X-B's start is
    logged before K-A's); UIDs the case's order X-A 1, K-A 2, X-B 3, M-C 4."""
    case = tiny_case.model_copy(update={"calendar": CALENDAR})
    root = parsed(mspdi.schedule_mspdi(make_events(), case))
    tasks = tasks_of(root)
    assert list(tasks) == ["X-A", "X-B", "K-A", "M-C"]
    expected = {  # name: (UID, ID, start s, finish s, duration, crew, component, type name)
        "X-A": (1, 1, 10, 130, "PT0H2M0S", "X-1", "A", "clean"),
        "X-B": (3, 2, 160, 280, "PT0H2M0S", "X-1", "B", "clean"),
        "K-A": (2, 3, 160, 300, "PT0H2M20S", "K-1", "A", "hoist"),
        "M-C": (4, 4, 370, 500, "PT0H2M10S", "M-1", "C", "reinforce"),
    }
    for name, (uid, row, start, finish, duration, crew, component, kind) in expected.items():
        t = tasks[name]
        get = lambda tag, t=t: t.findtext(f"p:{tag}", namespaces=NS)  # noqa: E731
        assert (int(get("UID")), int(get("ID"))) == (uid, row), name
        assert (get("Start"), get("Finish"), get("Duration")) == \
            (by_hand(start), by_hand(finish), duration), name
        assert get("ConstraintDate") == by_hand(start) and get("ConstraintType") == "4"
        values = {a.findtext("p:FieldID", namespaces=NS): a.findtext("p:Value", namespaces=NS)
                  for a in t.findall("p:ExtendedAttribute", NS)}
        assert values == {"188743731": component, "188743734": kind, "188743737": crew}
    # K-A ends at Friday's closing; M-C starts 70 s into Tuesday (Monday is the holiday)
    assert tasks["K-A"].findtext("p:Finish", namespaces=NS) == "2026-01-09T16:00:00"
    assert tasks["M-C"].findtext("p:Start", namespaces=NS) == "2026-01-13T08:01:10"
    assert tasks["M-C"].findtext("p:Notes", namespaces=NS) == "paused 1 time (40 s)"
    assert tasks["X-A"].find("p:Notes", NS) is None
    links = {n: [(int(link.findtext("p:PredecessorUID", namespaces=NS)),
                  link.findtext("p:Type", namespaces=NS))
                 for link in t.findall("p:PredecessorLink", NS)] for n, t in tasks.items()}
    assert links == {"X-A": [], "X-B": [], "K-A": [(1, "1")], "M-C": [(2, "1")]}  # FS
    resources = {r.findtext("p:UID", namespaces=NS): (r.findtext("p:Name", namespaces=NS),
                                                      r.findtext("p:Group", namespaces=NS))
                 for r in root.findall("p:Resources/p:Resource", NS)}
    assert resources == {"1": ("X-1", "cleaning crew"), "2": ("K-1", "hoisting crew"),
                         "3": ("M-1", "rebar crew"), "4": ("M-2", "rebar crew")}
    assignments = [(a.findtext("p:TaskUID", namespaces=NS),
                    a.findtext("p:ResourceUID", namespaces=NS),
                    a.findtext("p:Work", namespaces=NS))
                   for a in root.findall("p:Assignments/p:Assignment", NS)]
    assert assignments == [("1", "1", "PT0H2M0S"), ("3", "1", "PT0H2M0S"),
                           ("2", "2", "PT0H2M20S"), ("4", "3", "PT0H2M10S")]
    assert root.findtext("p:StartDate", namespaces=NS) == "2026-01-09T15:55:00"
    assert root.findtext("p:FinishDate", namespaces=NS) == by_hand(500)
    calendar = root.find("p:Calendars/p:Calendar", NS)
    days = {int(d.findtext("p:DayType", namespaces=NS)): d.findtext("p:DayWorking",
                                                                     namespaces=NS)
            for d in calendar.findall("p:WeekDays/p:WeekDay", NS)}
    assert days == {1: "0", 2: "1", 3: "1", 4: "1", 5: "1", 6: "1", 7: "0"}  # Sun .. Sat
    assert [e.findtext("p:TimePeriod/p:FromDate", namespaces=NS)
            for e in calendar.findall("p:Exceptions/p:Exception", NS)] == ["2026-01-12T00:00:00"]
    assert root.findtext("p:MinutesPerDay", namespaces=NS) == "480"


def test_without_a_calendar_the_default_start_dates_it(tiny_case):
    root = parsed(mspdi.schedule_mspdi(make_events(), tiny_case))
    assert tiny_case.calendar is None
    assert root.findtext("p:StartDate", namespaces=NS) == "2026-01-05T08:00:00"  # a Monday
    assert tasks_of(root)["X-A"].findtext("p:Start", namespaces=NS) == "2026-01-05T08:00:10"


def test_a_run_that_stopped_still_lists_every_task(tiny_case):
    """The log up to 160 s, stopped at 250 s: X-A finished; X-B and K-A started at 160 and
    run to the stop; M-C never started, 0 long at the stop."""
    case = tiny_case.model_copy(update={"calendar": CALENDAR})
    events = make_events([r for r in RUN if r[0] <= 160])
    tasks = tasks_of(parsed(mspdi.schedule_mspdi(events, case, end_s=250.0)))
    assert list(tasks) == ["X-A", "X-B", "K-A", "M-C"]
    row = {n: (t.findtext("p:Start", namespaces=NS), t.findtext("p:Finish", namespaces=NS),
               t.findtext("p:Duration", namespaces=NS), t.findtext("p:Notes", namespaces=NS))
           for n, t in tasks.items()}
    assert row["X-A"] == (by_hand(10), by_hand(130), "PT0H2M0S", None)
    assert row["K-A"] == (by_hand(160), by_hand(250), "PT0H1M30S",
                          "not finished when the simulation stopped")
    assert row["M-C"] == (by_hand(250), by_hand(250), "PT0H0M0S",
                          "not started when the simulation stopped")
    assert tasks["M-C"].findtext("p:Milestone", namespaces=NS) == "0"


def test_written_whole_and_the_same_bytes_twice(tmp_path, tiny_case):
    a = mspdi.write_mspdi(tmp_path / "a.xml", make_events(), tiny_case)
    b = mspdi.write_mspdi(tmp_path / "b.xml", make_events(), tiny_case)
    assert a.read_bytes() == b.read_bytes()
    assert a.read_bytes().startswith(b"<?xml version='1.0' encoding='UTF-8'?>")
    assert not list(tmp_path.glob(".*.tmp"))


def test_cmdp_simulate_writes_it_and_says_where_its_dates_come_from(tmp_path, capsys):
    """Without --start the file is dated from the default start, Mon 2026-01-05 08:00, and
    the console says so; each task starts that plus its schedule.csv start (the tiny floor
    ends within the first working day)."""
    import csv

    import cmdp_pymunk
    from training.commands import simulate

    out = tmp_path / "run"
    assert simulate.main(["--case", str(cmdp_pymunk.TINY_CASE), "--out", str(out),
                          "--no-progress", "--no-charts"]) == 0
    assert ("MS Project schedule (MSPDI XML) schedule.xml, no --start given: dated from the "
            "default start Mon 2026-01-05 08:00, working 08:00-16:00 Mon-Fri") \
        in capsys.readouterr().out
    with open(out / "schedule.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    tasks = tasks_of(parsed((out / "schedule.xml").read_bytes()))
    assert list(tasks) == [r["task"] for r in rows]
    zero = dt.datetime(2026, 1, 5, 8)
    for row in rows:
        assert float(row["end_s"]) < 8 * 3600
        start = zero + dt.timedelta(seconds=round(float(row["start_s"])))
        assert tasks[row["task"]].findtext("p:Start", namespaces=NS) == \
            start.isoformat(timespec="seconds")


# -- read back by MPXJ -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def mpxj_reader():
    """MPXJ's UniversalProjectReader (the JVM starts once per test process)."""
    if shutil.which("java") is None:
        pytest.skip("no Java runtime (java) on PATH: MPXJ needs one; install a JRE (e.g. "
                    "apt-get install default-jre-headless)")
    pytest.importorskip("mpxj", reason="mpxj is not installed: pip install -e '.[mspdi-test]'")
    import jpype

    if not jpype.isJVMStarted():
        jpype.startJVM()
    from org.mpxj.reader import UniversalProjectReader

    return UniversalProjectReader()


# slow: MPXJ's JVM starts in about 3.5 s and the floor plays for 2 more (9 s measured on the
# shared 2 cores); the hand-made tests above check the file's content in the gate
@pytest.mark.slow
def test_mpxj_reads_the_simulated_schedule_back(tmp_path, mpxj_reader, capsys):
    """cmdp-simulate on the tiny case (seed 3, its dates across a weekend and a holiday): MPXJ
    finds in schedule.xml the tasks, dates, durations, links and crews of schedule.csv."""
    import csv

    import cmdp_pymunk
    from training.commands import simulate

    out = tmp_path / "run"
    assert simulate.main(["--case", str(cmdp_pymunk.TINY_CASE), "--out", str(out), "--seed",
                          "3", "--no-progress", "--no-charts", "--start", "2026-01-09T15:30",
                          "--holidays", "2026-01-12"]) == 0
    assert "MS Project schedule (MSPDI XML) schedule.xml, dated from Fri 2026-01-09 15:30" \
        in capsys.readouterr().out
    with open(out / "schedule.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    project = mpxj_reader.read(str(out / "schedule.xml"))
    tasks = [t for t in project.getTasks() if t.getUniqueID() and int(t.getUniqueID()) > 0]
    assert [str(t.getName()) for t in tasks] == [r["task"] for r in rows]  # same tasks, order
    assert len(tasks) == len(case.tasks) == 3
    precedence = {t.id: set(t.predecessors) for t in case.tasks}
    for task, row in zip(tasks, rows, strict=True):
        assert str(task.getStart()) == row["start"] and str(task.getFinish()) == row["end"]
        duration = task.getDuration()
        assert str(duration.getUnits()) == "h"
        assert round(float(duration.getDuration()) * 3600) == round(float(row["duration_s"]))
        links = list(task.getPredecessors())
        assert {str(r.getPredecessorTask().getName()) for r in links} == precedence[row["task"]]
        assert all(str(r.getType()) == "FS" for r in links)
        crews = [(str(a.getResource().getName()), float(a.getUnits()))
                 for a in task.getResourceAssignments()]
        assert crews == [(row["crew"], 100.0)]
    assert {str(r.getName()) for r in project.getResources() if r.getName()} == \
        {c.id for c in case.crews}
    import java.time

    calendar = project.getDefaultCalendar()
    assert not calendar.isWorkingDate(java.time.LocalDate.of(2026, 1, 12))  # the holiday
    assert calendar.isWorkingDate(java.time.LocalDate.of(2026, 1, 13))
