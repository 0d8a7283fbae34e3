"""The case check across entries: cross-references, geometry and precedence, what
field-by-field validation (``field_problems``) cannot see.

``_semantic_problems`` runs five groups in the order their problems are listed: the task types
(crew types, materials, storages that supply them), where crews start (on the plane, not on
one point), ids used twice, the layout (components and storages on the plane and apart, what
stands on a component) and the tasks (types, components, predecessors, one task per crew type
per component, a crew for every task type, no precedence cycle: ``_find_cycle``). Each reads
the parts of the case that validated (``field_problems._Parts``), so it also runs on a case
with field errors.

Apart from ``load`` because these rules are the case's meaning (what the simulation needs to
hold), not the reading of a file.
"""

from __future__ import annotations

import graphlib
import math
from dataclasses import dataclass

from .. import geometry
from .field_problems import _LISTS, _did_you_mean, _Parts
from .floorplan import GEOMETRY_TOLERANCE_M, Rect
from .model import Component, Crew, Plane


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
