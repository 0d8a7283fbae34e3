"""Field by field: pydantic's errors on a case, reworded for a planner.

Each error names the entry the way the TOML file heads it (``tasks[12] "R-07": work``,
``crew_types.RC: velocity_m_s``), says what is wrong and gives the fix (``_pydantic_problems``);
``_did_you_mean`` suggests the nearest known name. When some entries fail, ``_parts`` keeps
those that validated, so the checks across entries (``case_check``, ``time_checks``) still run
on them and an entry with a field error is not also reported as an unknown reference.

Apart from ``load`` because it is a concern of its own (pydantic's locations and error kinds
turned into a planner's words) that reading a file does not need to show.
"""

from __future__ import annotations

import difflib
import types
from dataclasses import dataclass
from typing import Union, get_args, get_origin

from pydantic import BaseModel, ValidationError

from .model import (
    Case,
    Component,
    Crew,
    CrewType,
    Material,
    Plane,
    Storage,
    Task,
    TaskType,
)

_MAPPINGS = ("task_types", "crew_types", "materials")  # named tables: [task_types.R]
_LISTS = ("crews", "components", "storages", "tasks")  # arrays of tables: [[tasks]]
_ENTRY_MODELS = {"task_types": TaskType, "crew_types": CrewType, "materials": Material,
                 "crews": Crew, "components": Component, "storages": Storage, "tasks": Task}
_ABSENT = object()

# -- field by field: pydantic's errors, reworded ----------------------------------------------

_FIXES = {
    "float_parsing": "write a number",
    "float_type": "write a number (without quotes)",
    "int_type": "write a whole number (without quotes or a decimal point)",
    "int_parsing": "write a whole number",
    "int_from_float": "write a whole number",
    "string_type": 'write text in quotes, e.g. "A-01"',
    "bool_type": "write true or false (without quotes)",
    "tuple_type": 'write a list, e.g. ["A", "B"], or for a section [[section]] entries',
    "dict_type": "write a table",
    "model_type": "write a table",
    "too_short": "add at least one entry",
    "finite_number": "write a finite number (not nan or inf)",
}


def _toml_value(value: object) -> str:
    """A value as it would look in the file, for "got ..." in a message."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "a list"
    return repr(value)


def _entry_label(data: object, loc: tuple) -> str:
    """``tasks[12] "R-07": work`` or ``crew_types.RC: velocity_m_s`` from a pydantic location,
    naming list entries by their id and named tables the way the TOML file heads them."""
    parts: list[str] = []
    node = data
    for key in loc:
        if isinstance(key, int) and parts:
            node = node[key] if isinstance(node, (list, tuple)) and 0 <= key < len(node) else None
            parts[-1] += f"[{key}]"
            if isinstance(node, dict) and isinstance(node.get("id"), str):
                parts[-1] += f' "{node["id"]}"'
            continue
        if len(parts) == 1 and (parts[0] in _MAPPINGS or parts[0] == "disruptions"):
            parts[0] += f".{key}"
        else:
            parts.append(str(key))
        node = node.get(key) if isinstance(node, dict) else None
    return ": ".join(parts) if parts else "(top level)"


def _model_at(loc: tuple) -> type[BaseModel] | None:
    """The model class that holds the fields at a pydantic location (``()``: the case)."""
    model: object = Case
    skip = False
    for key in loc:
        if skip:  # a named table's key or a list index
            skip = False
            continue
        if not (isinstance(model, type) and issubclass(model, BaseModel)):
            return None
        field = model.model_fields.get(str(key))
        if field is None:
            return None
        model = field.annotation
        if get_origin(model) in (Union, types.UnionType):  # an optional section: its model
            model = next((a for a in get_args(model) if isinstance(a, type)
                          and issubclass(a, BaseModel)), None)
        if get_origin(model) in (dict, tuple):
            model = get_args(model)[1 if get_origin(model) is dict else 0]
            skip = True
    if skip or not (isinstance(model, type) and issubclass(model, BaseModel)):
        return None
    return model


def _is_index(loc: tuple) -> bool:
    """Whether the field at ``loc`` is an index in [0, 1] (congestion, invasion, deceleration)."""
    model = _model_at(loc[:-1])
    field = model.model_fields.get(str(loc[-1])) if model and loc else None
    if field is None:
        return False
    return (any(getattr(m, "ge", None) == 0 for m in field.metadata)
            and any(getattr(m, "le", None) == 1 for m in field.metadata))


def _fix(err: dict, loc: tuple) -> str:
    kind, ctx = err["type"], err.get("ctx", {})
    name = str(loc[-1]) if loc else ""
    if kind == "missing":
        if len(loc) == 1:
            return f"add [[{name}]] entries" if name in _LISTS else f"add a [{name}] section"
        return f"add {name} = ... to this entry"
    if kind == "extra_forbidden":
        model = _model_at(loc[:-1])
        known = list(model.model_fields) if model else []
        close = _closest(name, known)
        if close:
            return f'did you mean "{close}"?'
        return "remove it" + (f"; the fields here are {', '.join(known)}" if known else "")
    if kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        if _is_index(loc):
            return "an index lies in [0, 1]; use a value from 0 to 1"
        words = {"gt": "above", "ge": "of at least", "lt": "below", "le": "of at most"}
        bound = next(iter(ctx.items()), None)
        if bound and bound[0] == "gt" and bound[1] == 0:
            return "use a positive value"
        return f"use a value {words[bound[0]]} {bound[1]:g}" if bound else "use another value"
    return _FIXES.get(kind, "see docs/case-study.md for the field's meaning")


def _pydantic_problems(data: dict, error: ValidationError) -> list[str]:
    problems = []
    for err in error.errors():
        loc = tuple(k for k in err["loc"] if k != "function-after")
        # Union members add their type name to the location; it tells the user nothing.
        loc = tuple(k for k in loc if not (isinstance(k, str) and k in {"float", "none"}))
        msg = err["msg"].removeprefix("Value error, ")
        msg = {"missing": "required field missing", "extra_forbidden": "unknown field",
               "tuple_type": "Input should be a list", "dict_type": "Input should be a table",
               "model_type": "Input should be a table",
               "too_short": "needs at least one entry"}.get(err["type"], msg)
        quiet = ("missing", "extra_forbidden", "value_error", "too_short")
        if err["type"] not in quiet and "input" in err:
            msg += f" (got {_toml_value(err['input'])})"
        fix = "" if "; fix: " in msg else f"; fix: {_fix(err, loc)}"  # a validator's own
        problems.append(f"{_entry_label(data, loc)}: {msg}{fix}")
    return list(dict.fromkeys(problems))


# -- names: the known one nearest a misspelt one ---------------------------------------------

def _closest(name: str, known: list[str]) -> str | None:
    """The known name most like ``name`` (the first in file order among equals), or None."""
    for k in known:
        if k.casefold() == name.casefold():
            return k
    best, score = None, 0.6
    for k in known:
        ratio = difflib.SequenceMatcher(None, name, k).ratio()
        if ratio > score:
            best, score = k, ratio
    return best


def _did_you_mean(name: str, known: list[str]) -> str:
    close = _closest(name, known)
    if close is not None:
        return f'; did you mean "{close}"?'
    unique = list(dict.fromkeys(known))
    if not unique:
        return "; fix: define it first"
    if len(unique) <= 12:
        return "; fix: use one of " + ", ".join(f'"{k}"' for k in unique)
    return "; fix: use the id of an existing entry"


# -- what validated: the parts the checks across entries read -------------------------------

@dataclass
class _Parts:
    """What validated, with each list entry's index in the file, and every name the file
    defines whether its entry validated or not (None: the section is missing or unusable),
    so that an entry with a field error does not also show up as an unknown reference."""

    plane: Plane | None
    task_types: dict[str, TaskType]
    crew_types: dict[str, CrewType]
    materials: dict[str, Material]
    crews: list[tuple[int, Crew]]
    components: list[tuple[int, Component]]
    storages: list[tuple[int, Storage]]
    tasks: list[tuple[int, Task]]
    names: dict[str, list[str] | None]
    crew_types_on_crews: list[str] | None
    storage_materials: list[str] | None


def _valid(model: type[BaseModel], raw: object) -> BaseModel | None:
    try:
        return model.model_validate(raw)
    except ValidationError:
        return None


def _raw_field(data: dict, section: str, key: str) -> list[str] | None:
    """``key`` of every entry of a list section, as written (None: no usable list)."""
    raw = data.get(section, _ABSENT)
    if raw is _ABSENT and not Case.model_fields[section].is_required():
        return []
    if not isinstance(raw, (list, tuple)):  # tuples: a case built in Python
        return None
    return [e[key] for e in raw if isinstance(e, dict) and isinstance(e.get(key), str)]


def _parts(data: dict, case: Case | None) -> _Parts:
    """The validated case cut into parts, or, when it did not validate, the parts that did."""
    names: dict[str, list[str] | None] = {}
    for section in _MAPPINGS:
        raw = data.get(section, _ABSENT)
        if raw is _ABSENT and not Case.model_fields[section].is_required():
            names[section] = []
        else:
            names[section] = list(raw) if isinstance(raw, dict) else None
    for section in _LISTS:
        names[section] = _raw_field(data, section, "id")
    if case is not None:
        mappings = {s: dict(getattr(case, s)) for s in _MAPPINGS}
        lists = {s: list(enumerate(getattr(case, s))) for s in _LISTS}
        plane = case.plane
    else:
        mappings, lists = {}, {}
        for section in _MAPPINGS:
            raw = data.get(section)
            raw = raw if isinstance(raw, dict) else {}
            mappings[section] = {k: m for k, v in raw.items()
                                 if (m := _valid(_ENTRY_MODELS[section], v)) is not None}
        for section in _LISTS:
            raw = data.get(section)
            raw = raw if isinstance(raw, (list, tuple)) else []
            lists[section] = [(i, m) for i, v in enumerate(raw)
                              if (m := _valid(_ENTRY_MODELS[section], v)) is not None]
        plane = _valid(Plane, data.get("plane"))
    return _Parts(plane=plane, names=names,
                  crew_types_on_crews=_raw_field(data, "crews", "type"),
                  storage_materials=_raw_field(data, "storages", "material"),
                  **mappings, **lists)
