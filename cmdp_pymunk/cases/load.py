"""Loading and checking a case: a floor's work plane, its crews, components, tasks, storages.

A case is a TOML file a construction engineer can write by hand (see ``docs/case-study.md`` and
the built-in ``cases/precast_floor.toml``). Loading validates it completely before anything is
simulated: every problem is collected and reported in one :class:`CaseError`, each naming the
file, the entry and the fix. The models themselves (fields, units, coordinates) are in
``cmdp_pymunk.cases.model``, re-exported here.

This module reads a case (TOML, raw data) and runs the checks in their order
(``case_from_dict``); the checks live beside it: pydantic's errors in a planner's words and the
parts that validated (``field_problems``), cross-references, geometry and precedence
(``case_check``), time limits and disruptions (``time_checks``), ``[cost]`` and ``[levers]``
(``lever_checks``), reachability (``reach``). A working calendar on its own (a file, or
command-line options) is read here too.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from pydantic import ValidationError

# _find_cycle and _did_you_mean are re-exported: load.py held them before the split (issue 43),
# and the IFC overlay and storey, levers and the tests import them (and _closest) from here
from .case_check import _find_cycle, _semantic_problems  # noqa: F401
from .field_problems import (  # noqa: F401
    _closest,
    _did_you_mean,
    _parts,
    _pydantic_problems,
)
from .lever_checks import cost_problems, lever_problems
from .model import (  # noqa: F401  (re-exported: the models are part of this API)
    Calendar,
    Case,
    CaseInfo,
    Component,
    Crane,
    Crew,
    CrewType,
    Disruptions,
    EvaluationReward,
    Flag,
    Material,
    NonNegative,
    Number,
    Plane,
    Positive,
    ReachingReward,
    Simulation,
    Storage,
    Task,
    TaskType,
    UnitIndex,
)
from .reach import unreachable
from .time_checks import _disruption_problems, _time_problems

BUILTIN_CASE = Path(__file__).parent / "precast_floor.toml"
# the tiny case of the docs, the command-line tests and cmdp/TinyFloor-v1
TINY_CASE = Path(__file__).parent / "tiny_floor.toml"
# the built-in case with the documented disruption profile (docs/disruptions.md)
DISRUPTED_CASE = Path(__file__).parent / "precast_floor_disrupted.toml"
# the built-in case with a reorder point at half a crane lift per material (docs/results.md)
REORDER_CASE = Path(__file__).parent / "precast_floor_reorder.toml"


@dataclass
class CaseError(ValueError):
    """A case that cannot be simulated; ``problems`` lists every one found."""

    source: str
    problems: list[str]

    def __str__(self) -> str:
        lines = [f"{self.source}: {len(self.problems)} problem(s) in the case:"]
        lines += [f"  {self.source}: {p}" for p in self.problems]
        return "\n".join(lines)


def case_from_dict(data: dict, source: str = "<case>") -> Case:
    """Validate raw case data; raise :class:`CaseError` listing every problem.

    Field errors and cross-reference problems are reported together: when some entries do not
    validate, the cross-reference checks run on those that do.
    """
    if not isinstance(data, dict):
        raise CaseError(source, ["the case must be a table of sections; fix: start the file "
                                 "with [plane], [crane], [task_types.*], ... sections"])
    try:
        case: Case | None = Case.model_validate(data)
        problems: list[str] = []
    except ValidationError as err:
        case, problems = None, _pydantic_problems(data, err)
    parts = _parts(data, case)
    problems += [p for p in _semantic_problems(parts) if p not in problems]
    problems += [p for p in _disruption_problems(data, case, parts) if p not in problems]
    if case is not None:  # beyond the paper: [cost] and [levers] against the case
        problems += _cost_and_lever_problems(case)
    if case is not None and not problems:
        problems = _time_problems(case)
    if case is not None and not problems:  # the crews can reach their work: reach.py
        problems = unreachable(case)
    if problems:
        raise CaseError(source, problems)
    assert case is not None
    return case


def _cost_and_lever_problems(case: Case) -> list[str]:
    """``[cost]`` naming crew types the case lacks, and a bad ``[levers]`` section
    (``lever_checks``)."""
    return cost_problems(case) + lever_problems(case)


def _toml_problem(err: tomllib.TOMLDecodeError, text: str) -> str:
    """``line 12: malformed TOML: ... in 'width_m = = 2'``, from tomllib's message."""
    msg = str(err)
    where = re.search(r"\s*\(at line (\d+), column (\d+)\)", msg)
    if where is None:
        return f"malformed TOML: {msg}; fix: correct the syntax"
    line_no, column = int(where[1]), int(where[2])
    lines = text.splitlines()
    line = lines[line_no - 1].strip() if 0 < line_no <= len(lines) else ""
    return (f"line {line_no}: malformed TOML: {msg[:where.start()]} (column {column} of "
            f"{line!r}); fix: correct the syntax on that line")


def load_case(path: str | Path | None = None) -> Case:
    """Load and validate a case file (TOML); ``None`` loads the built-in case.

    Raises :class:`CaseError` (never another exception) for a file that cannot be read, is not
    TOML, or describes a case that cannot be simulated.
    """
    path = Path(path) if path is not None else BUILTIN_CASE
    return case_from_dict(_read_toml(path), path.name or str(path))


def _read_toml(path: Path) -> dict:
    """A TOML file's data, or :class:`CaseError` naming the file and the fix."""
    source = path.name or str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as err:
        reason = err.strerror or type(err).__name__
        raise CaseError(str(path), [f"cannot read the file ({reason}); fix: check the path "
                                    "and that it names a readable file"]) from None
    except UnicodeDecodeError as err:
        raise CaseError(source, [f"is not UTF-8 text (byte {err.start}); "
                                 "fix: save the file as UTF-8"]) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise CaseError(source, [_toml_problem(err, text)]) from None


# -- the working calendar on its own: a file or command-line options ----------------------

def calendar_with(base: Calendar | None, given: dict[str, object], source: str,
                  labels: dict[str, str] | None = None) -> Calendar:
    """``base`` (None: no calendar yet) with the ``given`` entries replaced (a value of None:
    not given), validated; :class:`CaseError` naming ``source``, each entry by its ``labels``
    name (default ``calendar: FIELD``) and the fix.

    What ``cmdp-simulate --calendar FILE`` and ``--start``, ``--working-hours``, ... make of a
    case's ``[calendar]``.
    """
    raw = base.model_dump(mode="json") if base is not None else {}
    raw.update({k: v for k, v in given.items() if v is not None})
    try:
        return Calendar.model_validate(raw)
    except ValidationError as err:
        labels = labels or {}
        problems = []
        for e in err.errors():
            name = str(e["loc"][0]) if e["loc"] else ""
            label = labels.get(name, f"calendar: {name}")
            if e["type"] == "missing":  # only the start is required
                fix = (f"give {label} 2026-01-05T08:00, or a start in the case's [calendar]"
                       if name in labels else "add start = 2026-01-05T08:00:00 to [calendar]")
                problems.append(f"{label}: required field missing (a calendar needs a start); "
                                f"fix: {fix}")
            elif e["type"] == "extra_forbidden":
                close = _closest(name, list(Calendar.model_fields))
                fix = f'did you mean "{close}"?' if close else \
                    "the fields here are " + ", ".join(Calendar.model_fields)
                problems.append(f"{label}: unknown field; fix: {fix}")
            else:
                msg = e["msg"].removeprefix("Value error, ")
                problems.append(f"{label}: {msg}" if "; fix: " in msg
                                else f"{label}: {msg}; fix: see docs/simulating.md")
        raise CaseError(source, problems) from None


def load_calendar(path: str | Path) -> Calendar:
    """The ``[calendar]`` table of a TOML file (a case file or one holding only that table);
    :class:`CaseError` naming the file, the entry and the fix."""
    path = Path(path)
    data = _read_toml(path)
    raw = data.get("calendar")
    if not isinstance(raw, dict):
        raise CaseError(path.name, ["no [calendar] table; fix: put the entries under a "
                                    "[calendar] heading (start, working_hours, working_days, "
                                    "holidays), as in a case file"])
    return calendar_with(None, raw, path.name)


def as_case(case: Case | str | Path | dict | None) -> Case:
    """Accept a Case, a path, raw data or None (the built-in case)."""
    if isinstance(case, Case):
        return case
    if isinstance(case, dict):
        return case_from_dict(case)
    return load_case(case)


__all__ = ["Case", "CaseError", "load_case", "case_from_dict", "as_case", "BUILTIN_CASE",
           "TINY_CASE", "DISRUPTED_CASE", "Calendar", "calendar_with", "load_calendar"]
