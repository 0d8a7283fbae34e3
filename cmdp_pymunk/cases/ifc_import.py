"""Floors from BIM, the input side: a storey of an IFC model as a case (the 4D output is
``cases.ifc_export``).

**Import** (``cmdp-import-ifc``, :func:`import_storey`). The storey's elements of the recipe's
IFC classes (by default slabs, columns, walls and members are precast, beams are cast in place;
``floorplan.PRECAST_RECIPE``) become components: each element's plan footprint (its body
geometry projected on the floor, in metres) is boxed in the axis-aligned rectangle the
simulator needs; an element without a body of its own takes its footprint from its parts (the
elements aggregated to it, which are then no components). An element that its rectangle covers
poorly (the footprint fills less than ``[import] min_fill`` of it: an L-shape, a beam at 45
degrees) is reported, not silently boxed, and so is an element that does not sit on its storey:
the bottom of its body lies outside the storey's range, from halfway down to the storey below
to halfway up to the one above (``ifc_storey.StoreyRange``). What blocks walking is decided by
elevation: elements of the ``[import] supports`` classes whose body lies wholly below the
storey's working level (beams and columns under the slabs, walls of the storey below) carry the
floor and are no components (``ifc_storey.split_supports``). That level comes from the
overlay's ``[import] level_m``, else the storey's Elevation, its placement or its slabs' tops
(``ifc_levels.working_level``); the notes and every refusal that depends on it name it and
its route. Footprints may touch and cross by
``GEOMETRY_TOLERANCE_M``, the case check's tolerance too. Tasks come from the recipe's chains:
JC -> HI -> G on a precast component, R -> F on a cast-in-place one, R waiting for HI on the
components beside it (``neighbour_gap_m``). Where the model carries a 4D schedule, its
sequences replace the recipe's links between components (``ifc_schedule``).

Crews, crane, storages and the plane's margin come from a small overlay TOML (``ifc_overlay``,
docs/ifc.md). The plane is the components' bounding box grown by the margins, centred on the
origin; storages and the crane stand in the margins above and below, crews start in the left
margin.

This module builds the case (:func:`build_case`) and runs the import; its parts are apart,
each module saying why: ``ifc_overlay`` (the overlay), ``ifc_model`` (opening the model, the
elements' footprints), ``ifc_storey`` (the storey's range and level, supports, decks) and
``ifc_schedule`` (the model's 4D schedule). The names the docs gave as
``cmdp_pymunk.cases.ifc_import.X`` are still importable from here (``__all__``).

IfcOpenShell is an optional dependency (``pip install -e '.[ifc]'`` in a checkout), imported only
when a function is called.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ..geometry import Outline, as_polygon
from ..geometry import overlap as shapes_overlap
from .floorplan import (
    GEOMETRY_TOLERANCE_M,
    Recipe,
    StorageSpot,
    bounding_rect,
    narrow_lanes,
    neighbours,
    overlapping_pairs,
    plan_case,
)
from .ifc_levels import describe, how_to_set
from .ifc_model import Element, IfcUnavailable, _component_ids, open_model, storey_elements
from .ifc_overlay import Overlay, load_overlay
from .ifc_schedule import ModelSchedule, _schedule_cycle, _sequence_predecessors, model_schedule
from .ifc_storey import (
    StoreyRange,
    _working_level,
    deck_slabs,
    find_storey,
    split_supports,
    storey_names,
)
from .load import CaseError, case_from_dict

__all__ = [
    "TIME_LIMIT_S_PER_TASK", "ImportReport", "build_case", "crew_types_with_work",
    "crews_left_out", "import_storey",
    # re-exported: the API docs and the commands named them ``cases.ifc_import.X``
    "IfcUnavailable", "Overlay", "load_overlay", "open_model", "storey_names",
]

TIME_LIMIT_S_PER_TASK = 1000.0  # as the generated layouts: at least this much per task


@dataclass
class ImportReport:
    """What the import took, made and noticed, for the command's summary."""

    components_by_class: dict[str, int]
    skipped_by_class: dict[str, int]
    tasks: int
    precedences: str  # "recipe" or "model"
    notes: list[str]
    provenance: dict[str, str] = field(default_factory=dict)  # ``Overlay.provenance``
    crews_left_out: dict[str, int] = field(default_factory=dict)  # crew type -> crews, no work
    # IFC class -> elements that carry the floor from below its level (not components)
    supports_by_class: dict[str, int] = field(default_factory=dict)
    level_m: float | None = None  # the storey's working level; None: it has none
    level_route: str = "none"  # where it came from (``ifc_levels.ROUTES``)


def crew_types_with_work(elements: Sequence[Element], recipe: Recipe,
                         task_types: dict) -> set[str]:
    """The crew types that the recipe's chains give work on these elements (a slabs-only
    recipe needs no reinforcing or formwork crew)."""
    types = {step.type for e in elements for step in recipe.chains.get(e.kind, ())}
    return {task_types[t]["crew_type"] for t in types if t in task_types}


def crews_left_out(elements: Sequence[Element], overlay: Overlay) -> dict[str, int]:
    """The overlay's crews (type -> count) of the types without work on these elements."""
    working = crew_types_with_work(elements, overlay.recipe, overlay.base["task_types"])
    return {ct: n for ct, n in overlay.data["crews"].items() if n and ct not in working}


def _r(v: float) -> float:
    """Millimetres: enough for a floor, and no float noise in the case file."""
    return round(v, 3) + 0.0


def _plan_corners(outline: tuple, cx: float, cy: float) -> list[list[float]]:
    """An outline's corners on the plane (centred on (cx, cy)), in millimetres (``_r``),
    without a corner that rounding made twice."""
    out: list[list[float]] = []
    for x, y in outline:
        p = [_r(x - cx), _r(y - cy)]
        if not out or p != out[-1]:
            out.append(p)
    if len(out) > 1 and out[0] == out[-1]:
        out.pop()
    return out


def _off_storey(e: Element, storey: StoreyRange) -> str:
    """The message for an element whose body starts outside its storey's range."""
    bottom = e.z_m[0]
    near = storey.sits_on(bottom)
    if near is not None:
        where = f'nearer storey "{near.name}" (level {near.level_m:.2f} m) than its own'
        fix = (f'assign it to "{near.name}" in the model (IfcRelContainedInSpatialStructure) '
               "or correct its placement")
    else:
        where = "on no storey of the building"
        fix = "correct its placement in the model (its elevation, or its unit)"
    return (f'{e.label}: sits at z {bottom:.2f} m (the bottom of its body), outside storey '
            f'"{storey.name}" ({storey.level}: its elements start from '
            f"{storey.low_m:.2f} m up to {storey.high_m:.2f} m), {where}; fix: {fix}, or take "
            "the storey's elements as assigned with [import] check_storey = false in the "
            f"overlay; if the storey's level is wrong, {how_to_set(storey.route)}")


def _overlap(a: Element, b: Element, size: tuple[float, float],
             storey: StoreyRange | None) -> str:
    """The message for two footprints that overlap: whether one carries the other (a
    support) is decided against the storey's level, so it names that level, its route and
    how to set it."""
    if storey is None:
        carried = (f"the storey has {describe(None, 'none')}, so nothing is taken as a "
                   f"support: {how_to_set('none')}, with the carrying one below it and its "
                   "class in [import] supports in the overlay")
    else:
        carried = (f"model it below the storey's level ({storey.level}; its top at most "
                   f"{GEOMETRY_TOLERANCE_M * 1000:g} mm above it) and list its class in "
                   f"[import] supports in the overlay; if the level is wrong, "
                   f"{how_to_set(storey.route)}")
    w, h = size
    return (f"{a.label} and {b.label}: footprints overlap by {w:.3f} x {h:.3f} m (components "
            "are obstacles side by side on the floor); fix: correct the model so that they "
            f"only touch; if one carries the other, {carried}; or leave one of the classes "
            "out of the recipe ([recipe.classes] in the overlay)")


def build_case(elements: Sequence[Element], overlay: Overlay, schedule: ModelSchedule | None,
               name: str, description: str, ids: Sequence[str], source: str,
               storey: StoreyRange | None = None) -> tuple[dict, list[str], str]:
    """The case data of a storey's elements (footprints checked; each element's height
    against ``storey``'s range unless the overlay's ``import.check_storey`` is false), the
    notes, and where the precedences came from ("recipe" or "model")."""
    notes: list[str] = []
    polygons = overlay.data["import"]["polygons"] is True
    drawn = {k for k, e in enumerate(elements) if polygons and e.outline is not None}
    _check_footprints(elements, drawn, overlay, storey, source, notes)
    rects = [e.rect for e in elements]
    cx, cy, half_w, half_h = _plane_of(elements, rects, drawn, overlay, storey, source)
    components = _components(elements, ids, drawn, cx, cy)
    _decks_and_lanes(elements, rects, components, overlay, notes)  # marks the decks
    recipe = overlay.recipe
    with_tasks = [k for k, e in enumerate(elements) if recipe.chains.get(e.kind)]
    use_model = schedule is not None and bool(schedule.sequences)
    ends = {} if use_model else {
        ids[k]: [ids[j] for j in neighbours(rects, k, with_tasks, recipe.neighbour_gap_m)]
        for k in with_tasks}
    crews = _crews_with_work(elements, overlay, notes)
    storages = [StorageSpot(st["id"], st["material"], st["width_m"], st["height_m"],
                            st["capacity"], st.get("congestion_index_full", 0.5),
                            1 if st.get("edge", "top") == "top" else -1,
                            _r(float(st.get("x_frac", 0.0)) * half_w))
                for st in overlay.data["storages"]]
    data = plan_case(name=name, description=description, half_width_m=half_w,
                     half_height_m=half_h, base=overlay.base, crane_times=overlay.data["crane"],
                     crews=crews, storages=storages, components=components, recipe=recipe,
                     ends=ends, time_limit_s_per_task=TIME_LIMIT_S_PER_TASK)
    data["case"].update(overlay.data.get("case", {}))
    tasks = data["tasks"]
    _check_tasks_manned(tasks, elements, overlay, source)
    if use_model:
        _model_precedences(schedule, tasks, source)
        notes += schedule.notes
    return data, notes, "model" if use_model else "recipe"


def _check_footprints(elements: Sequence[Element], drawn: set[int], overlay: Overlay,
                      storey: StoreyRange | None, source: str, notes: list[str]) -> None:
    """Each element's footprint: a body to take it from, on the storey, with an extent in
    plan, and a rectangle it fills enough (or a polygon imported as drawn: ``drawn``, by
    index); a ``CaseError`` with every problem, else the notes (``notes``, appended) on
    polygons and boxed ones."""
    problems = []
    min_fill = float(overlay.data["import"]["min_fill"])
    check_storey = storey is not None and overlay.data["import"]["check_storey"]
    for k, e in enumerate(elements):
        if e.rect is None:
            problems.append(f"{e.label}: has no body geometry to take a footprint from, "
                            "neither its own nor its parts' (elements aggregated to it, "
                            "IfcRelAggregates); fix: give it a body representation, or "
                            "aggregate the elements that carry its body to it, or leave its "
                            "class out of the recipe")
        elif check_storey and e.z_m is not None and not storey.holds(e.z_m[0]):
            problems.append(_off_storey(e, storey))
        elif min(e.rect.size) <= 1e-6:
            problems.append(f"{e.label}: its footprint has no extent in plan "
                            f"({e.rect.size[0]:.3g} x {e.rect.size[1]:.3g} m; an element out "
                            "of the floor's plane); fix: model it as a solid on the floor, or "
                            "leave its class out of the recipe")
        elif k in drawn:
            notes.append(f"{e.label}: imported as drawn, a polygon of {len(e.outline)} corners "
                         f"filling {e.fill:.0%} of its rectangle")
        elif e.fill < min_fill:
            w, h = e.rect.size
            problems.append(f"{e.label}: its footprint fills {e.fill:.0%} of its {w:.2f} x "
                            f"{h:.2f} m rectangle (components are axis-aligned rectangles), "
                            f"less than import.min_fill = {min_fill:g}; fix: split it into "
                            "rectangular elements in the model, or accept the rectangle with "
                            f"[import] min_fill = {math.floor(e.fill * 100) / 100:g} in the "
                            "overlay")
        elif e.fill < 0.999:
            notes.append(f"{e.label}: boxed, its footprint fills {e.fill:.0%} of its rectangle")
    if problems:
        raise CaseError(source, problems)


def _plane_of(elements: Sequence[Element], rects: list, drawn: set[int], overlay: Overlay,
              storey: StoreyRange | None, source: str) -> tuple[float, float, float, float]:
    """The plane round the footprints: their centre (cx, cy) and the plane's half extents,
    the overlay's margins or its fixed size; a ``CaseError`` for footprints that overlap or
    lie outside a fixed plane."""
    problems = []
    for i, j in overlapping_pairs(rects):  # beyond GEOMETRY_TOLERANCE_M, as the case check
        size = rects[i].overlap(rects[j])
        if i in drawn or j in drawn:  # a polygon's box may reach over what it leaves free
            a, b = (Outline(elements[k].outline) if k in drawn else tuple(rects[k])
                    for k in (i, j))
            if not shapes_overlap(a, b, GEOMETRY_TOLERANCE_M):
                continue
            x0, y0, x1, y1 = as_polygon(a).intersection(as_polygon(b)).bounds
            size = (x1 - x0, y1 - y0)
        problems.append(_overlap(elements[i], elements[j], size, storey))
    box = bounding_rect(rects)
    cx, cy = box.centre
    plane_cfg = overlay.data["plane"]
    half_w = _r((box.x1 - box.x0) / 2 + plane_cfg["margin_x_m"])
    half_h = _r((box.y1 - box.y0) / 2 + plane_cfg["margin_y_m"])
    if "width_m" in plane_cfg or "height_m" in plane_cfg:  # a fixed plane
        fixed_w = plane_cfg.get("width_m", 2 * half_w) / 2
        fixed_h = plane_cfg.get("height_m", 2 * half_h) / 2
        for e in elements:
            x0, x1 = e.rect.x0 - cx, e.rect.x1 - cx
            y0, y1 = e.rect.y0 - cy, e.rect.y1 - cy
            if x0 < -fixed_w or x1 > fixed_w or y0 < -fixed_h or y1 > fixed_h:
                problems.append(f"{e.label}: its footprint x {x0:.2f}..{x1:.2f}, y {y0:.2f}.."
                                f"{y1:.2f} m lies outside the plane [-{fixed_w:g}, {fixed_w:g}]"
                                f" x [-{fixed_h:g}, {fixed_h:g}] set in the overlay; fix: widen "
                                "plane.width_m / height_m, or drop them to fit the storey")
        half_w, half_h = _r(fixed_w), _r(fixed_h)
    if problems:
        raise CaseError(source, problems)
    return cx, cy, half_w, half_h


def _components(elements: Sequence[Element], ids: Sequence[str], drawn: set[int], cx: float,
                cy: float) -> list[dict]:
    """Each element as a component entry, centred on the plane; one imported as drawn with
    its outline and the box of the outline's rounded corners."""
    components = []
    for k, (e, cid) in enumerate(zip(elements, ids, strict=True)):
        x, y = e.rect.centre
        w, h = e.rect.size
        entry = {"id": cid, "kind": e.kind, "x_m": _r(x - cx), "y_m": _r(y - cy),
                 "width_m": _r(w), "height_m": _r(h), "ifc_guid": e.guid}
        if k in drawn:  # as drawn: its outline, and the box of the outline's rounded corners
            corners = _plan_corners(e.outline, cx, cy)
            xs, ys = [p[0] for p in corners], [p[1] for p in corners]
            entry.update(x_m=(min(xs) + max(xs)) / 2, y_m=(min(ys) + max(ys)) / 2,
                         width_m=max(xs) - min(xs), height_m=max(ys) - min(ys),
                         outline=corners)
        components.append(entry)
    return components


def _decks_and_lanes(elements: Sequence[Element], rects: list, components: list[dict],
                     overlay: Overlay, notes: list[str]) -> set[int]:
    """The slabs that form decks (marked ``deck`` on their components) and the notes on them
    and on lanes narrower than the widest crew (but a deck's joints); returns the decks."""
    crew_types = overlay.base["crew_types"]
    widest = max(2 * math.sqrt(crew_types[ct]["occupation_area_m2"] / math.pi)
                 for ct in overlay.data["crews"] if overlay.data["crews"][ct] > 0) \
        if any(overlay.data["crews"].values()) else 0.0
    decks = deck_slabs(elements, float(overlay.data["import"]["deck_joint_max_m"]))
    for k in decks:
        components[k]["deck"] = True
    if decks:
        notes.append(f"{len(decks)} IfcSlab side by side with joints of at most "
                     f"{overlay.data['import']['deck_joint_max_m']:g} m ([import] "
                     "deck_joint_max_m) form decks: obstacles until installed, walked on after")
    for i, j, gap in narrow_lanes(rects, widest):
        if i in decks and j in decks:  # a joint in a deck: walked over once both are laid
            continue
        notes.append(f"the lane between {elements[i].label} and {elements[j].label} is "
                     f"{gap:.2f} m wide, narrower than the widest crew ({widest:.2f} m): no "
                     "crew passes there")
    return decks


def _crews_with_work(elements: Sequence[Element], overlay: Overlay,
                     notes: list[str]) -> list[tuple[str, str]]:
    """The overlay's crews, (id, type), of the types that have work here: an idle crew type
    would wait all floor and become an IfcCrewResource with nothing to do in the 4D model."""
    left_out = crews_left_out(elements, overlay)
    crews = [(f"{ct}-{k + 1}", ct) for ct, n in overlay.data["crews"].items()
             if ct not in left_out for k in range(n)]
    if left_out:
        notes.append("no work for crew type(s) "
                     + ", ".join(f"{ct} ({n} crew{'s' if n > 1 else ''})"
                                 for ct, n in left_out.items())
                     + " on this storey: left out of the case")
    return crews


def _check_tasks_manned(tasks: list[dict], elements: Sequence[Element], overlay: Overlay,
                        source: str) -> None:
    """Some task on the storey, and a crew in the overlay for every task type in use (a
    ``CaseError`` naming the fix)."""
    if not tasks:
        raise CaseError(source, ["the recipe gives the storey's elements no tasks (their kinds "
                                 "have no chain); fix: add [recipe.chains] for "
                                 + ", ".join(sorted({e.kind for e in elements}))])
    task_types = overlay.base["task_types"]
    unmanned = {}
    for t in tasks:
        crew_type = task_types[t["type"]]["crew_type"]
        if not overlay.data["crews"].get(crew_type):
            unmanned.setdefault((t["type"], crew_type), []).append(t["id"])
    if unmanned:
        raise CaseError(overlay.source, [
            f"task type {tt} ({len(ids_)} task(s) on the storey, e.g. {ids_[0]}) needs a "
            f'"{ct}" crew, and [crews] has none; fix: add {ct} = 1 to the overlay\'s [crews]'
            for (tt, ct), ids_ in unmanned.items()])


def _model_precedences(schedule: ModelSchedule, tasks: list[dict], source: str) -> None:
    """The model's 4D schedule's sequences added to the tasks' predecessors (a cycle: a
    ``CaseError``)."""
    cycle = _schedule_cycle(schedule)
    if cycle:
        raise CaseError(source, ["the model's 4D schedule has a cycle of IfcRelSequence: "
                                 + " -> ".join(schedule.tasks[g][0] for g in cycle)
                                 + "; fix: remove one of these sequences in the model"])
    chains: dict[str, list[str]] = {}
    for t in tasks:
        chains.setdefault(t["component"], []).append(t["id"])
    types = {t["id"]: t["type"] for t in tasks}
    extra = _sequence_predecessors(schedule, chains, types)
    for t in tasks:
        if t["id"] in extra:
            t["predecessors"] = list(dict.fromkeys(t.get("predecessors", [])
                                                   + extra[t["id"]]))


def import_storey(model_path: str | Path, storey: str, overlay: Overlay | None = None
                  ) -> tuple[dict, ImportReport]:
    """A storey of an IFC model as case data, checked by ``case_from_dict``.

    Raises :class:`CaseError` (the model, the overlay or the case it makes cannot be used;
    every problem named) or :class:`IfcUnavailable`.
    """
    overlay = overlay or load_overlay(None)
    model = open_model(model_path)
    source = Path(model_path).name
    level = find_storey(model, storey, source)
    elements, skipped = storey_elements(model, level, overlay.recipe)
    storey_span, level_notes = _working_level(model, level, elements, overlay)
    elements, supports = split_supports(elements, storey_span,
                                        overlay.data["import"]["supports"])
    if not elements:
        found = ", ".join(f"{n} {c}" for c, n in sorted(skipped.items())) or "no elements"
        held = (f"; {len(supports)} element(s) of it lie below its {storey_span.level} and "
                "carry it ([import] supports; if the level is wrong, "
                f"{how_to_set(storey_span.route)})" if supports else "")
        raise CaseError(source, [f'storey "{storey}" has no elements of the recipe\'s classes '
                                 f"({', '.join(overlay.recipe.classes)}) on its floor; it holds "
                                 f"{found}{held}; fix: pick another storey, or map its classes "
                                 "to kinds in the overlay's [recipe.classes]"])
    ids = _component_ids(elements)
    schedule = model_schedule(model, {e.guid: cid for e, cid in zip(elements, ids,
                                                                    strict=True)},
                              overlay.recipe)
    name = f"{Path(model_path).stem}-{level.Name or level.GlobalId}"
    description = (f"imported from {source}, storey {level.Name or level.GlobalId}, by "
                   "cmdp-import-ifc")
    data, notes, precedences = build_case(elements, overlay, schedule, name, description, ids,
                                          source, storey_span)
    unchecked = [what for what, on in (
        ("its elements' heights are not checked", overlay.data["import"]["check_storey"]),
        ("none is taken as a support under its floor ([import] supports)",
         bool(overlay.data["import"]["supports"]))) if on]
    if storey_span is None and unchecked:
        notes.insert(0, f'storey "{level.Name or level.GlobalId}" has {describe(None, "none")}: '
                        + ", and ".join(unchecked) + f"; fix: {how_to_set('none')}")
    notes[:0] = level_notes
    from_parts: dict[str, tuple[int, set[str]]] = {}
    for e in elements:
        if e.parts_from:
            n, classes = from_parts.get(e.ifc_class, (0, set()))
            from_parts[e.ifc_class] = (n + 1, classes | set(e.parts_from))
    for cls, (n, classes) in sorted(from_parts.items()):
        notes.append(f"{n} {cls} without a body of {'its' if n == 1 else 'their'} own: "
                     f"footprint{'' if n == 1 else 's'} from the elements aggregated to "
                     f"{'it' if n == 1 else 'them'} ({', '.join(sorted(classes))}), which are "
                     "not components")
    case_from_dict(data, f"the case made from {source}")
    by_class: dict[str, int] = {}
    for e in elements:
        by_class[e.ifc_class] = by_class.get(e.ifc_class, 0) + 1
    carried: dict[str, int] = {}
    for e in supports:
        carried[e.ifc_class] = carried.get(e.ifc_class, 0) + 1
    return data, ImportReport(by_class, skipped, len(data["tasks"]), precedences, notes,
                              overlay.provenance(), crews_left_out(elements, overlay),
                              dict(sorted(carried.items())),
                              level_m=storey_span.level_m if storey_span else None,
                              level_route=storey_span.route if storey_span else "none")
