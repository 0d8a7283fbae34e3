"""Loading and checking a case: a floor's work plane, its crews, components, tasks, storages.

A case is a TOML file a construction engineer can write by hand (see ``docs/case-study.md`` and
the built-in ``cases/precast_floor.toml``). Loading validates it completely before anything is
simulated: every problem is collected and reported in one :class:`CaseError`, each naming the
file, the entry and the fix. The models themselves (fields, units, coordinates) are in
``cmdp_pymunk.cases.model``, re-exported here.
"""

from __future__ import annotations

import difflib
import graphlib
import math
import re
import tomllib
import types
from dataclasses import dataclass
from pathlib import Path
from typing import Union, get_args, get_origin

from pydantic import BaseModel, ValidationError

from .. import geometry
from .floorplan import GEOMETRY_TOLERANCE_M, Rect
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


# -- across entries: references, geometry, precedence ----------------------------------------

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


def _rect(item) -> Rect:
    return Rect.centred(item.x_m, item.y_m, item.width_m, item.height_m)


def _overlap(a: Rect, b: Rect) -> bool:
    """Whether the interiors meet by more than :data:`GEOMETRY_TOLERANCE_M` (the importer's
    tolerance too): touching edges, and the float noise of centring, are no overlap."""
    return a.overlaps(b, GEOMETRY_TOLERANCE_M)


def _plan_overlap(a, b) -> tuple[float, float] | None:
    """The size (x, y, m) of where two case entries (components, storages) overlap in plan
    beyond :data:`GEOMETRY_TOLERANCE_M`, or None. Rectangles by their rectangles (as before
    polygons); a component with an ``outline`` by its polygon, so a notched slab's box may
    reach over a neighbour that the slab itself leaves free."""
    ra, rb = _rect(a), _rect(b)
    if not _overlap(ra, rb):
        return None
    if getattr(a, "outline", None) is None and getattr(b, "outline", None) is None:
        return ra.overlap(rb)
    sa = a.shape if getattr(a, "outline", None) else tuple(ra)
    sb = b.shape if getattr(b, "outline", None) else tuple(rb)
    if not geometry.overlap(sa, sb, GEOMETRY_TOLERANCE_M):
        return None
    x0, y0, x1, y1 = geometry.as_polygon(sa).intersection(geometry.as_polygon(sb)).bounds
    return x1 - x0, y1 - y0


def _on_component(comp: Component, x: float, y: float) -> bool:
    """Whether the point (x, y) lies on the component (its rectangle, or its outline)."""
    return bool(geometry.contains(comp.shape if comp.outline else tuple(_rect(comp)), x, y))


def _components_overlap(i: int, comp: Component, j: int, other: Component,
                        size: tuple[float, float]) -> str:
    """The message for two components whose rectangles overlap by ``size`` (x, y, metres).
    A component imported from IFC (it has ``ifc_guid``) is named by id and GlobalId, and the
    fix is the BIM user's: its case entry is written by the importer, the model is what to
    correct."""
    by = f"by {size[0]:.3f} x {size[1]:.3f} m (more than the {GEOMETRY_TOLERANCE_M:g} m tolerance)"
    if comp.ifc_guid is None and other.ifc_guid is None:
        return (f'components[{i}] "{comp.id}": overlaps components[{j}] "{other.id}" {by}; '
                "fix: move or shrink one of them")

    def name(c: Component) -> str:
        return f'"{c.id}"' + (f" (IFC GlobalId {c.ifc_guid})" if c.ifc_guid else "")

    return (f"component {name(comp)} overlaps component {name(other)} in plan {by}; fix: "
            "find the two elements in the BIM model by GlobalId and correct their geometry "
            "so that they only touch (or leave one's class out of the import recipe), then "
            "import the storey again with cmdp-import-ifc")


def _shared_start_problems(parts: _Parts) -> list[str]:
    """Crews that start on one point: one crew's start lies inside the other's body (a disc of
    its crew type's occupation area), as for two entries copied with only the id changed. Two
    discs on one centre have no direction to part in, and the event floor would stack them, so
    such a case is refused. Discs that only overlap at their edges are accepted, as a crew
    starting against a component is: the physics pushes them apart in the first steps (the
    IFC importer packs crews that way on a small storey)."""
    problems: list[str] = []
    placed: list[tuple[int, Crew, float]] = []
    for i, crew in parts.crews:
        ct = parts.crew_types.get(crew.type)
        if ct is None:  # an unknown crew type is reported on its own
            continue
        for j, other, r_other in placed:
            apart = math.hypot(crew.start_x_m - other.start_x_m, crew.start_y_m - other.start_y_m)
            inside = max(ct.radius_m, r_other)
            if apart < inside - GEOMETRY_TOLERANCE_M:
                problems.append(
                    f'crews[{i}] "{crew.id}": starts at ({crew.start_x_m:g}, {crew.start_y_m:g}),'
                    f' {apart:.2f} m from crews[{j}] "{other.id}" at ({other.start_x_m:g}, '
                    f"{other.start_y_m:g}), inside one of their bodies ({ct.radius_m:.2f} m and "
                    f"{r_other:.2f} m radius): both would start on one point; fix: choose a "
                    f"free start point, at least {inside:.2f} m from the other crew's "
                    f"({ct.radius_m + r_other:.2f} m keeps the bodies apart)")
        placed.append((i, crew, ct.radius_m))
    return problems


def _semantic_problems(parts: _Parts) -> list[str]:
    """Cross-references, geometry and precedence: what field-by-field validation cannot see.
    One group a function, in the order the problems are listed: the task types, where crews
    start, ids used twice, the layout (components, storages, what stands on them), the tasks."""
    frame = _Frame.of(parts.plane)
    return (_task_type_problems(parts) + _start_problems(parts, frame)
            + _duplicate_id_problems(parts) + _layout_problems(parts, frame)
            + _task_problems(parts))


def _unknown(parts: _Parts, section: str, name: str) -> bool:
    """``name`` is not among the names the file defines in ``section`` (a section missing or
    unusable is reported apart: nothing in it is unknown)."""
    return parts.names[section] is not None and name not in parts.names[section]


@dataclass(frozen=True)
class _Frame:
    """The plane's extent as the checks word it (None where the plane did not validate)."""

    half_w: float
    half_h: float
    bounds: str  # "[-w, w] x [-h, h]", for the messages

    @classmethod
    def of(cls, plane: Plane | None) -> _Frame | None:
        if plane is None:
            return None
        half_w, half_h = plane.half_extents
        return cls(half_w, half_h, f"[-{half_w:g}, {half_w:g}] x [-{half_h:g}, {half_h:g}]")

    def outside(self, x0: float, y0: float, x1: float, y1: float) -> bool:
        return x0 < -self.half_w or x1 > self.half_w or y0 < -self.half_h or y1 > self.half_h


def _task_type_problems(parts: _Parts) -> list[str]:
    """Each task type's crew type and material (known, supplied by a storage, carried), and
    one material per crew type."""
    problems: list[str] = []
    names = parts.names
    for name, tt in parts.task_types.items():
        where = f"task_types.{name}"
        if _unknown(parts, "crew_types", tt.crew_type):
            problems.append(f'{where}: crew_type names unknown crew type "{tt.crew_type}"'
                            f"{_did_you_mean(tt.crew_type, names['crew_types'])}")
        if tt.material is None:
            continue
        if _unknown(parts, "materials", tt.material):
            problems.append(f'{where}: material "{tt.material}" is not in [materials]'
                            f"{_did_you_mean(tt.material, names['materials'])}")
        elif parts.storage_materials is not None and tt.material not in parts.storage_materials:
            problems.append(f'{where}: material "{tt.material}" has no storage that supplies it; '
                            f'fix: add a [[storages]] entry with material = "{tt.material}"')
        crew_type = parts.crew_types.get(tt.crew_type)
        if crew_type is not None and crew_type.carry_capacity <= 0:
            problems.append(f"crew_types.{tt.crew_type}: carry_capacity must be positive because "
                            f'its task type {name} needs material "{tt.material}"; '
                            "fix: set carry_capacity")
    materials_of: dict[str, dict[str, str]] = {}
    for name, tt in parts.task_types.items():
        if tt.material is not None:
            materials_of.setdefault(tt.crew_type, {}).setdefault(tt.material, name)
    for crew_type, mats in materials_of.items():
        if len(mats) > 1:  # a crew holds one material (state.CrewState.material)
            listed = ", ".join(f'{t} needs "{m}"' for m, t in mats.items())
            problems.append(f"crew_types.{crew_type}: its task types need different materials "
                            f"({listed}) but a crew carries one; "
                            "fix: give these task types to different crew types")
    return problems


def _start_problems(parts: _Parts, frame: _Frame | None) -> list[str]:
    """The outlet and the crews' starts on the plane, the crews' types, shared starts."""
    problems: list[str] = []
    plane = parts.plane
    if frame is not None and not (abs(plane.outlet_x_m) <= frame.half_w
                                  and abs(plane.outlet_y_m) <= frame.half_h):
        problems.append(f"plane: the outlet ({plane.outlet_x_m:g}, {plane.outlet_y_m:g}) "
                        f"lies outside the plane {frame.bounds}; fix: move it onto the plane")
    for i, crew in parts.crews:
        where = f'crews[{i}] "{crew.id}"'
        if _unknown(parts, "crew_types", crew.type):
            problems.append(f'{where}: type names unknown crew type "{crew.type}"'
                            f"{_did_you_mean(crew.type, parts.names['crew_types'])}")
        if frame is not None and not (abs(crew.start_x_m) < frame.half_w
                                      and abs(crew.start_y_m) < frame.half_h):
            problems.append(f"{where}: start ({crew.start_x_m:g}, {crew.start_y_m:g}) is outside "
                            f"the plane {frame.bounds}; fix: move it inside")
    return problems + _shared_start_problems(parts)


def _duplicate_id_problems(parts: _Parts) -> list[str]:
    """An id used twice within one list section."""
    problems: list[str] = []
    for section in _LISTS:
        seen: set[str] = set()
        for item_id in parts.names[section] or ():
            if item_id in seen:
                problems.append(f'{section}: id "{item_id}" is used twice; fix: rename one')
            seen.add(item_id)
    return problems


def _layout_problems(parts: _Parts, frame: _Frame | None) -> list[str]:
    """Components and storages on the plane and apart, storages' materials and reorder points,
    the outlet and the crews' starts off the components."""
    problems: list[str] = []
    placed: list[tuple[int, Component, tuple]] = []
    for i, comp in parts.components:
        r = _rect(comp)
        where = f'components[{i}] "{comp.id}"'
        if frame is not None and frame.outside(*r):
            problems.append(f"{where}: rectangle x {r[0]:g}..{r[2]:g}, y {r[1]:g}..{r[3]:g} "
                            f"lies outside the plane {frame.bounds}; fix: move or shrink it")
        for j, other, _ro in placed:
            if (size := _plan_overlap(comp, other)) is not None:
                problems.append(_components_overlap(i, comp, j, other, size))
        placed.append((i, comp, r))
    for i, st in parts.storages:
        where = f'storages[{i}] "{st.id}"'
        for j, comp, _rc in placed:
            if _plan_overlap(st, comp) is not None:
                problems.append(f'{where}: overlaps components[{j}] "{comp.id}" (crews could '
                                "not stand in it to fetch); fix: move the storage off the "
                                "component")
        if _unknown(parts, "materials", st.material):
            problems.append(f'{where}: material "{st.material}" is not in [materials]'
                            f"{_did_you_mean(st.material, parts.names['materials'])}")
        elif (mat := parts.materials.get(st.material)) is not None and \
                mat.reorder_at >= st.capacity:
            problems.append(f"{where}: its capacity ({st.capacity:g}) is at most "
                            f"materials.{st.material}.reorder_at ({mat.reorder_at:g}), so it "
                            "would be re-ordered on every fetch; fix: set reorder_at below "
                            "the capacity (0: order when empty)")
        if frame is not None and frame.outside(*_rect(st)):
            problems.append(f"{where}: lies outside the plane {frame.bounds}; fix: move it "
                            "inside")

    plane = parts.plane
    if plane is not None:
        for j, comp, _rc in placed:
            if _on_component(comp, plane.outlet_x_m, plane.outlet_y_m):
                problems.append(f"plane: the outlet ({plane.outlet_x_m:g}, {plane.outlet_y_m:g})"
                                f' lies inside components[{j}] "{comp.id}"; fix: move the '
                                "outlet onto open floor")
    for i, crew in parts.crews:
        for j, comp, _rc in placed:
            # centre inside: a disc that only overlaps the edge is pushed off by the physics
            if _on_component(comp, crew.start_x_m, crew.start_y_m):
                problems.append(f'crews[{i}] "{crew.id}": start ({crew.start_x_m:g}, '
                                f'{crew.start_y_m:g}) lies inside components[{j}] "{comp.id}"'
                                "; fix: start the crew on open floor")
    return problems


def _task_problems(parts: _Parts) -> list[str]:
    """Each task's type, material and component, its predecessors, one task per crew type per
    component, a crew for every task type in use, and no precedence cycle."""
    problems: list[str] = []
    names = parts.names
    tasks_of_type: dict[str, list[str]] = {}
    for i, task in parts.tasks:
        where = f'tasks[{i}] "{task.id}"'
        if _unknown(parts, "task_types", task.type):
            problems.append(f'{where}: type names unknown task type "{task.type}"'
                            f"{_did_you_mean(task.type, names['task_types'])}")
        else:
            tasks_of_type.setdefault(task.type, []).append(where)
            tt = parts.task_types.get(task.type)
            if tt is not None and tt.material is None and task.material_quantity > 0:
                problems.append(f"{where}: material_quantity is {task.material_quantity:g} but "
                                f"task type {task.type} needs no material; fix: remove "
                                "material_quantity or give the task type a material")
        if _unknown(parts, "components", task.component):
            problems.append(f'{where}: names component "{task.component}" which does not exist'
                            f"{_did_you_mean(task.component, names['components'])}")
        for pred in task.predecessors:
            if pred == task.id:
                problems.append(f"{where}: precedes itself; fix: remove it from predecessors")
            elif _unknown(parts, "tasks", pred):
                problems.append(f'{where}: precedence names unknown task "{pred}"'
                                f"{_did_you_mean(pred, names['tasks'])}")
    # The decision table targets components: one task per crew type per component, or the
    # crew could not tell which of them a reach is for.
    seen_on: dict[tuple[str, str], str] = {}
    for i, task in parts.tasks:
        tt = parts.task_types.get(task.type)
        if tt is None:
            continue
        key = (task.component, tt.crew_type)
        if key in seen_on:
            problems.append(f'tasks[{i}] "{task.id}": component "{task.component}" already has '
                            f'a task for crew type {tt.crew_type} ("{seen_on[key]}"); fix: '
                            "merge them, or put one on another component")
        else:
            seen_on[key] = task.id
    for type_name, users in tasks_of_type.items():
        tt = parts.task_types.get(type_name)
        crew_types_on_crews = parts.crew_types_on_crews
        if (tt is None or not crew_types_on_crews  # no crews at all: reported already
                or _unknown(parts, "crew_types", tt.crew_type)
                or tt.crew_type in crew_types_on_crews):
            continue
        problems.append(f"task_types.{type_name}: no crew performs this task type (it needs a "
                        f'"{tt.crew_type}" crew), yet {len(users)} task(s) have it, e.g. '
                        f'{users[0]}; fix: add a [[crews]] entry with type = "{tt.crew_type}"')
    cycle = _find_cycle([task for _, task in parts.tasks])
    if cycle:
        first = next(i for i, t in parts.tasks if t.id == cycle[0])
        problems.append(f'tasks[{first}] "{cycle[0]}": precedence cycle '
                        + " -> ".join(cycle)
                        + " (each must end before the next starts); "
                        "fix: remove one of these predecessors")
    return problems


def _time_problems(case: Case) -> list[str]:
    """Times and quantities so large that no episode could finish within the time limit.

    Each check is a floor under any schedule: one task's expected duration, one crane lift,
    the crane's total busy time, one fetch, walking across the plane, and the makespan lower
    bound (``bounds``). A run that could never finish would only stall.
    """
    from ..bounds import expected_duration_s, lower_bound

    limit = case.simulation.max_time_s
    over = f"beyond simulation.max_time_s = {limit:g} s, so no episode could finish"
    fix_limit = "or raise simulation.max_time_s"
    problems = []
    for name, value in (("lift_time_s", case.crane.lift_time_s),
                        ("assist_time_s", case.crane.assist_time_s)):
        if value >= limit:
            problems.append(f"crane: {name} = {value:g} s is {over}; fix: give the time of one "
                            f"lift in seconds (the paper's crane takes minutes) {fix_limit}")
    for i, task in enumerate(case.tasks):
        seconds = expected_duration_s(case, task)
        if seconds >= limit:
            problems.append(f'tasks[{i}] "{task.id}": its expected duration ({seconds:.4g} s '
                            f"at the crew type's mean pace) is {over}; fix: check work, the "
                            f"crew type's pace and its unit, {fix_limit}")
    crane_s = 0.0
    for name, mat in case.materials.items():
        needed = sum(t.material_quantity for t in case.tasks
                     if case.task_types[t.type].material == name)
        crane_s += math.ceil(needed / mat.crane_lift_quantity) * case.crane.lift_time_s
        for ct_name, ct in case.crew_types.items():
            carries = any(tt.crew_type == ct_name and tt.material == name
                          for tt in case.task_types.values())
            if carries and ct.carry_capacity / mat.acquire_per_min * 60.0 >= limit:
                problems.append(f"materials.{name}: acquire_per_min = {mat.acquire_per_min:g} "
                                f"fills a {ct_name} crew's load ({ct.carry_capacity:g}) in "
                                f"more than the time limit, {over}; fix: check "
                                f"acquire_per_min and carry_capacity, {fix_limit}")
    crane_s += sum(case.crane.assist_time_s for t in case.tasks
                   if case.task_types[t.type].needs_crane)
    if crane_s >= limit and not problems:
        problems.append(f"crane: its lifts and assistance add up to {crane_s:.4g} s, {over}; "
                        f"fix: check lift_time_s, assist_time_s and the materials' "
                        f"crane_lift_quantity, {fix_limit}")
    across = case.plane.width_m + case.plane.height_m
    for name, ct in case.crew_types.items():
        if across / ct.velocity_m_s >= limit:
            problems.append(f"crew_types.{name}: velocity_m_s = {ct.velocity_m_s:g} takes "
                            f"{across / ct.velocity_m_s:.4g} s to cross the plane, {over}; "
                            f"fix: give the velocity in metres per second, {fix_limit}")
    if not problems:
        bound = lower_bound(case)
        if bound.lower_bound_s >= limit:
            problems.append(f"simulation: max_time_s = {limit:g} s is below the makespan lower "
                            f"bound of {bound.lower_bound_s:.0f} s (critical path "
                            f"{' -> '.join(bound.critical_path[:4])}"
                            f"{' ...' if len(bound.critical_path) > 4 else ''}), so no episode "
                            "could finish; fix: raise max_time_s, or check the tasks' work and "
                            "the crews' paces")
    return problems


# -- disruptions: references, times, overlaps --------------------------------------------

_DISRUPTION_KINDS = {"crane_breakdowns": None, "late_deliveries": ("storage", "storages"),
                     "absences": ("crew", "crews"), "weather_stops": None}
_MAX_CHECKED_WINDOWS = 10000  # repeats of one scheduled entry checked for overlaps


def _scheduled_windows(entry, limit: float) -> list[tuple[float, float]]:
    """The windows [start, end) of a scheduled entry that start before ``limit``."""
    out, start = [], entry.at_s
    while start < limit and len(out) < _MAX_CHECKED_WINDOWS:
        out.append((start, start + entry.duration_s))
        if entry.every_s is None:
            break
        start += entry.every_s
    return out


def _disruption_problems(data: dict, case: Case | None, parts: _Parts) -> list[str]:
    """What field-by-field validation of ``[disruptions]`` cannot see: unknown storages and
    crews, durations or starts beyond the time limit, overlapping absences of one crew."""
    if case is not None:
        disruptions, simulation = case.disruptions, case.simulation
    else:
        disruptions = _valid(Disruptions, data.get("disruptions", {}))
        simulation = _valid(Simulation, data.get("simulation", {}))
    if not disruptions:
        return []
    limit = simulation.max_time_s if simulation is not None else None
    problems: list[str] = []
    absences: dict[str, list[tuple[float, float, str]]] = {}
    for kind, ref in _DISRUPTION_KINDS.items():
        for i, entry in enumerate(getattr(disruptions, kind)):
            where = f"disruptions.{kind}[{i}]"
            if ref is not None:
                field, section = ref
                name, known = getattr(entry, field), parts.names[section]
                if known is not None and name not in known:
                    problems.append(f'{where}: {field} "{name}" is not in [[{section}]]'
                                    f"{_did_you_mean(name, known)}")
            if limit is None:
                continue
            duration = "duration_s" if entry.duration_s is not None else "duration_mean_s"
            if entry.longest_s >= limit:
                problems.append(f"{where}: {duration} = {entry.longest_s:g} s is not shorter "
                                f"than simulation.max_time_s = {limit:g} s, so the floor "
                                f"could not finish; fix: shorten {duration} (seconds, not "
                                "minutes?) or raise simulation.max_time_s")
            if entry.at_s is not None and entry.at_s >= limit:
                problems.append(f"{where}: at_s = {entry.at_s:g} s is not before "
                                f"simulation.max_time_s = {limit:g} s, so it never happens; "
                                "fix: give a start within the time limit, or remove the entry")
            if entry.mean_interval_s is not None and entry.mean_interval_s >= limit:
                problems.append(f"{where}: mean_interval_s = {entry.mean_interval_s:g} s is not "
                                f"shorter than simulation.max_time_s = {limit:g} s, so it "
                                "would rarely happen at all; fix: give the mean seconds "
                                "between occurrences within the time limit, or remove it")
            if kind == "absences" and entry.scheduled and entry.longest_s < limit:
                absences.setdefault(entry.crew, []).extend(
                    (a, b, where) for a, b in _scheduled_windows(entry, limit))
    for crew, windows in absences.items():
        windows.sort()
        for (a0, b0, w0), (a1, _, w1) in zip(windows, windows[1:], strict=False):
            if a1 < b0:
                problems.append(f'{w1}: crew "{crew}" is already absent from {a0:g} s to '
                                f"{b0:g} s ({w0}), and this absence starts at {a1:g} s; fix: "
                                "start it after the other ends, or merge the two entries")
                break
    return problems


def _find_cycle(tasks) -> list[str] | None:
    """A precedence cycle in precedence order (predecessor first; the first id repeated last),
    or None. ``graphlib`` finds it; the cycle is turned to start at the task listed first in
    the case, so that the message is the same whichever way the search ran."""
    preds = {t.id: [p for p in t.predecessors if p != t.id] for t in tasks}
    try:
        graphlib.TopologicalSorter(preds).prepare()
    except graphlib.CycleError as err:
        # args[1]: nodes each an immediate predecessor of the next, the first repeated last
        cycle = list(err.args[1][:-1])
        order = {task_id: i for i, task_id in enumerate(preds)}
        start = min(range(len(cycle)), key=lambda k: order.get(cycle[k], len(order)))
        cycle = cycle[start:] + cycle[:start]
        return cycle + [cycle[0]]
    return None


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
