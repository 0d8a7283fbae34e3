"""``schedule.xml`` written as text (``mspdi.XmlText``) is byte for byte what
``xml.etree.ElementTree`` writes for the same elements (``mspdi.ElementTreeXml``, the way the
file was written before): on the hand-made run of the tiny case with a holiday calendar, a
run that stopped, a run in which nothing started, and text that needs escaping."""

from __future__ import annotations

import pytest
from conftest import RUN, make_events

from cmdp_pymunk.cases.model import Calendar
from cmdp_pymunk.exchange import mspdi

CALENDAR = Calendar(start="2026-01-09T15:55", holidays=["2026-01-12", "2026-01-14"])


def both(events, case, end_s=None) -> tuple[bytes, bytes]:
    return (mspdi.schedule_mspdi(events, case, end_s),
            mspdi.schedule_mspdi(events, case, end_s, writer=mspdi.ElementTreeXml))


@pytest.mark.parametrize("calendar", [None, CALENDAR], ids=["default calendar", "holidays"])
def test_the_hand_made_run_gives_elementtrees_bytes(tiny_case, calendar):
    case = tiny_case.model_copy(update={"calendar": calendar})
    text, reference = both(make_events(), case)
    assert text == reference
    assert b"<Notes>paused 1 time (40 s)</Notes>" in text  # the run's pause made it in
    assert (b"<Exception>" in text) == (calendar is not None)


def test_a_stopped_run_and_an_empty_one_give_elementtrees_bytes(tiny_case):
    """Stopped at 250 s (tasks unfinished and unstarted, with notes); and a log without a
    task: empty ``Assignments``, which ElementTree writes as ``<Assignments />``."""
    case = tiny_case.model_copy(update={"calendar": CALENDAR})
    stopped = make_events([r for r in RUN if r[0] <= 160])
    text, reference = both(stopped, case, 250.0)
    assert text == reference
    assert b"not started when the simulation stopped" in text
    text, reference = both(make_events(RUN[:4]), case, 100.0)
    assert text == reference
    assert b"  <Assignments />\n" in text


def test_text_that_needs_escaping_gives_elementtrees_bytes(tiny_case):
    """A case named with XML's special characters: escaped in Name and Title as ElementTree
    escapes them."""
    name = tiny_case.case.model_copy(update={"name": 'a & b <c> "d"'})
    case = tiny_case.model_copy(update={"case": name})
    text, reference = both(make_events(), case)
    assert text == reference
    assert b"<Name>a &amp; b &lt;c&gt; \"d\".xml</Name>" in text


def test_the_writers_agree_on_empty_and_nested_elements():
    """Each call of the writer protocol alone: an empty root with an attribute to escape, a
    leaf with empty text, an element left open at the end."""
    for calls in ([], [("leaf", "A", "")], [("leaf", "A", None), ("open", "B"), ("close",)],
                  [("open", "B"), ("open", "C"), ("leaf", "D", 1)]):
        out = []
        for writer in (mspdi.XmlText, mspdi.ElementTreeXml):
            x = writer("R", {"k": 'x"<&\n'})
            for name, *args in calls:
                getattr(x, name)(*args)
            out.append(x.document())
        assert out[0] == out[1], calls
