"""What the event floor cannot derive, as data: a small TOML fitted on the pymunk floor.

Three numbers per crew type (``CrewTypeCalibration``):

- ``walk_factor``: a walk's time over its Eq. 1 time along the shortest path (turning toward
  the path, docking at the target, swerving around other crews, detours);
- ``task_invasion`` and ``fetch_invasion``: Eq. 2's n * I_agent expected while the crew works
  on a task or loads at a storage: on the pymunk floor the crews standing in the area, on the
  event floor their expectation.

They are fitted by ``cmdp-calibrate`` (``training.eventfloor.fitting``) on Eq. 9's pymunk
floors of training seeds (0-19), so that each crew type's walking, working and loading
crew-seconds on the event floor match the pymunk floor's, and written beside the case as
``<case file stem>.event.toml``::

    [event_floor]
    case = "precast-floor"
    fingerprint = "3f2a..."   # the floor the numbers were fitted on (``fingerprint``)
    fitted_on = "priority, seeds 0-19, pymunk floor"
    command = "cmdp-calibrate --case ... --seeds 0-19"

    [event_floor.crew_types.RC]
    walk_factor = 1.31
    task_invasion = 0.04
    fetch_invasion = 0.02

A file fitted on another floor is refused (its fingerprint: plane, crews, components, tasks,
storages and the crew, task and material types; not the disruptions, the calendar or the
simulation's limits, so the disrupted built-in case runs on the built-in calibration).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import tomllib
from pathlib import Path
from typing import Annotated

import tomli_w
from pydantic import BaseModel, ConfigDict, Field, Strict, ValidationError

from ..cases.load import BUILTIN_CASE, CaseError
from ..cases.model import Case

CASES_DIR = BUILTIN_CASE.parent
SUFFIX = ".event.toml"
# the parts of a case that the event floor's numbers depend on (``fingerprint``)
FLOOR_PARTS = ("plane", "crane", "task_types", "crew_types", "materials", "crews",
               "components", "storages", "tasks")

Factor = Annotated[float, Strict(), Field(gt=0, le=20, allow_inf_nan=False)]
Invasion = Annotated[float, Strict(), Field(ge=0, lt=1, allow_inf_nan=False)]


class CrewTypeCalibration(BaseModel):
    """One crew type's fitted numbers (see the module doc); the defaults are uncalibrated."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    walk_factor: Factor = 1.0
    dock_s: Annotated[float, Strict(), Field(ge=0, le=600, allow_inf_nan=False)] = 0.0
    task_invasion: Invasion = 0.0
    fetch_invasion: Invasion = 0.0


class Calibration(BaseModel):
    """The event floor's numbers for one floor (see the module doc)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    case: str
    fingerprint: str
    fitted_on: str = ""
    command: str = ""
    crew_types: dict[str, CrewTypeCalibration] = {}

    def of(self, crew_type: str) -> CrewTypeCalibration:
        return self.crew_types.get(crew_type, UNCALIBRATED)

    @property
    def calibrated(self) -> bool:
        return bool(self.fitted_on)


UNCALIBRATED = CrewTypeCalibration()


def fingerprint(case: Case) -> str:
    """A short hash of the floor a calibration is fitted on (``FLOOR_PARTS`` of the case)."""
    data = case.model_dump(mode="json", include=set(FLOOR_PARTS))
    for material in data.get("materials", {}).values():
        # a reorder point is the site's logistics, not what walks and invasion are fitted on:
        # a calibration holds for the same floor ordering earlier (and keeps its fingerprint)
        material.pop("reorder_at", None)
    text = json.dumps(data, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def uncalibrated(case: Case) -> Calibration:
    """Every crew type at walk factor 1 and no invasion: Eq. 1 and the drawn paces alone."""
    return Calibration(case=case.case.name, fingerprint=fingerprint(case))


def load_calibration(path: str | Path, case: Case) -> Calibration:
    """A calibration file for ``case``; a ``CaseError`` naming the file, the entry and the fix
    for a file that cannot be read, is not one, or was fitted on another floor."""
    path = Path(path)
    source = str(path)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as err:
        raise CaseError(source, [f"cannot read the calibration ({err.strerror or err}); fix: "
                                 "check the path, or make one with cmdp-calibrate"]) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise CaseError(source, [f"is not a TOML file ({err}); fix: write it again with "
                                 "cmdp-calibrate"]) from None
    if not isinstance(raw.get("event_floor"), dict):
        raise CaseError(source, ["has no [event_floor] table; fix: an event floor calibration "
                                 "is written by cmdp-calibrate"])
    try:
        calibration = Calibration.model_validate(raw["event_floor"])
    except ValidationError as err:
        problems = [f"event_floor.{'.'.join(str(p) for p in e['loc'])}: {e['msg']}; fix: "
                    "write the file again with cmdp-calibrate" for e in err.errors()]
        raise CaseError(source, problems) from None
    unknown = sorted(set(calibration.crew_types) - set(case.crew_types))
    if unknown and calibration.fingerprint == fingerprint(case):
        raise CaseError(source, [f"event_floor.crew_types: {', '.join(unknown)} not crew "
                                 f"types of the case ({', '.join(sorted(case.crew_types))}); "
                                 "fix: remove them, or write the file again with "
                                 "cmdp-calibrate"])
    if calibration.fingerprint != fingerprint(case):
        raise CaseError(source, [
            f"was fitted on another floor (case {calibration.case!r}, fingerprint "
            f"{calibration.fingerprint}; this case {case.case.name!r} is {fingerprint(case)}); "
            "fix: calibrate this case with cmdp-calibrate --case <its file>, or give the "
            "calibration made for it"])
    return calibration


def beside(case_path: str | Path) -> Path:
    """Where the calibration of a case file lives: ``<stem>.event.toml`` beside it."""
    case_path = Path(case_path)
    return case_path.with_name(case_path.stem + SUFFIX)


def calibration_path(case: Case, case_path: str | Path | None = None,
                     path: str | Path | None = None) -> Path | None:
    """Where the calibration of an event floor of ``case`` comes from (``calibration_for``):
    ``path`` if given; else the file beside ``case_path``; else a built-in one fitted on the
    same floor; None: none (uncalibrated)."""
    if path is not None:
        return Path(path)
    if case_path is not None and beside(case_path).is_file():
        return beside(case_path)
    mark = fingerprint(case)
    for candidate in sorted(CASES_DIR.glob("*" + SUFFIX)):
        try:
            raw = tomllib.loads(candidate.read_text(encoding="utf-8"))
        except (OSError, tomllib.TOMLDecodeError):
            continue
        table = raw.get("event_floor")
        if isinstance(table, dict) and table.get("fingerprint") == mark:
            return candidate
    return None


def calibration_for(case: Case, case_path: str | Path | None = None,
                    path: str | Path | None = None) -> Calibration:
    """The calibration an event floor of ``case`` runs on: ``path`` if given (checked);
    else the one beside ``case_path``; else a built-in one fitted on the same floor (the
    built-in case's serves its disrupted variant); else ``uncalibrated`` (Eq. 1 and the
    paces alone: the CLI says so). ``calibration_path`` says which file."""
    found = calibration_path(case, case_path, path)
    return uncalibrated(case) if found is None else load_calibration(found, case)


HEADER = ("# The event floor's calibration (cmdp_pymunk.eventfloor.calibration); written by\n"
          "# cmdp-calibrate: refit with the command below after changing the case.\n\n")


def calibration_toml(calibration: Calibration) -> str:
    """``calibration`` as the text of a ``.event.toml`` file (``tomli_w``: any name or command,
    newlines and quotes included, reads back the same); the fitted numbers to 4 decimals."""
    table = {key: getattr(calibration, key) for key in ("case", "fingerprint", "fitted_on",
                                                        "command")}
    table["crew_types"] = {name: {k: round(float(v), 4) for k, v in ct.model_dump().items()}
                           for name, ct in sorted(calibration.crew_types.items())}
    return HEADER + tomli_w.dumps({"event_floor": table})


def write_calibration(calibration: Calibration, path: str | Path) -> Path:
    """Write ``calibration`` as TOML, whole or not at all (a temporary file renamed)."""
    path = Path(path)
    text = calibration_toml(calibration)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


__all__ = ["Calibration", "CrewTypeCalibration", "UNCALIBRATED", "fingerprint", "uncalibrated",
           "load_calibration", "beside", "calibration_for", "calibration_path",
           "write_calibration", "calibration_toml"]
