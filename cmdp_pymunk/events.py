"""The append-only event log: task starts, pauses, resumes, finishes, crew state changes.

Gantt charts, trajectories and summaries are drawn from it (and from its CSV) alone.

``events.csv`` has one row per event: ``time_s, kind, crew, subject, detail, x_m, y_m,
heading_deg``. A ``position`` event (a moving crew, every ``position_log_every_s``) fills the
last three (metres, the plane's origin at its centre; degrees counter-clockwise from +x) and
leaves ``subject`` empty; every other event leaves them empty. In memory a position's subject
is the text ``"x,y,heading"`` (``position`` reads it); :func:`read_csv` also reads logs written
before the three columns existed, with the position packed in ``subject``.
"""

from __future__ import annotations

import csv
import io
import os
import tempfile
from pathlib import Path
from typing import NamedTuple


class Event(NamedTuple):
    time_s: float
    kind: str  # task_start, task_pause, task_resume, task_finish, crew_state, reach, crane_*
    crew: str
    subject: str  # a task, storage or target id, or the new crew state
    detail: str = ""


FIELDS = Event._fields
POSITION_FIELDS = ("x_m", "y_m", "heading_deg")
CSV_FIELDS = (*FIELDS, *POSITION_FIELDS)


class EventLog:
    def __init__(self) -> None:
        self.events: list[Event] = []

    def add(self, time_s: float, kind: str, crew: str, subject: str, detail: str = "") -> None:
        self.events.append(Event(float(time_s), kind, crew, subject, detail))

    def to_csv(self) -> str:
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(CSV_FIELDS)
        blank = ("",) * len(POSITION_FIELDS)
        for e in self.events:
            if e.kind == "position":
                writer.writerow((*e._replace(subject=""), *e.subject.split(",")))
            else:
                writer.writerow((*e, *blank))
        return buf.getvalue()

    def write_csv(self, path: str | Path) -> None:
        """Written to a temporary file, then renamed: never half a log on disk."""
        write_atomic(Path(path), self.to_csv())


def read_csv(path: str | Path) -> list[Event]:
    """The events of an ``events.csv``, as :meth:`EventLog.to_csv` wrote them (or the older
    layout without position columns)."""
    with open(path, newline="", encoding="utf-8") as f:
        return [Event(float(r["time_s"]), r["kind"], r["crew"], _subject(r), r["detail"])
                for r in csv.DictReader(f)]


def _subject(row: dict) -> str:
    if row["kind"] == "position" and row.get("x_m"):
        return ",".join(row[k] for k in POSITION_FIELDS)
    return row["subject"]


def position(event: Event) -> tuple[float, float, float]:
    """A ``position`` event's x (m), y (m) and heading (degrees)."""
    x, y, heading = event.subject.split(",")
    return float(x), float(y), float(heading)


def write_atomic(path: Path, text: str | bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(text.encode("utf-8") if isinstance(text, str) else text)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def set_status(site, log: EventLog, crew, status) -> None:
    """Change a crew's status, logging the change."""
    if crew.status != status:
        crew.status = status
        log.add(site.time_s, "crew_state", crew.id, status.name.lower())
