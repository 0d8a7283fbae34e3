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
to halfway up to the one above (:class:`StoreyRange`). What blocks walking is decided by
elevation: elements of the ``[import] supports`` classes whose body lies wholly below the
storey's working level (beams and columns under the slabs, walls of the storey below) carry the
floor and are no components (:func:`split_supports`). That level comes from the overlay's
``[import] level_m``, else the storey's Elevation, its placement or its slabs' tops
(``ifc_levels.working_level``); the notes and every refusal that depends on it name it and
its route. Footprints may touch and cross by
``GEOMETRY_TOLERANCE_M``, the case check's tolerance too. Tasks come from the recipe's chains:
JC -> HI -> G on a precast component, R -> F on a cast-in-place one, R waiting for HI on the
components beside it (``neighbour_gap_m``).

Where the model carries a 4D schedule (IfcTask assigned to the storey's elements with
IfcRelAssignsToProduct, or the elements to the task with IfcRelAssignsToProcess;
IfcRelSequence between such tasks), its sequences replace the
recipe's links between components: a sequence A -> B makes the first task of B's chain on each
of B's elements wait for the last task of A's chain on each of A's elements (a task whose
Identification or Name holds a recipe task type as a word, e.g. "HI S-1", stands for that
task alone). Chains within a component stay. The simulator's precedences are finish-to-start:
other sequence types and lags are reported and read as finish-to-start.

Crews, crane, storages and the plane's margin come from a small overlay TOML
(:data:`DEFAULT_OVERLAY`, docs/ifc.md); task types, crew types and materials from the built-in
case unless the overlay gives its own. The plane is the components' bounding box grown by the
margins, centred on the origin; storages and the crane stand in the margins above and below,
crews start in the left margin.

IfcOpenShell is an optional dependency (``pip install -e '.[ifc]'`` in a checkout), imported only
when a function here is called.
"""

from __future__ import annotations

import graphlib
import math
import re
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ..geometry import Outline, as_polygon
from ..geometry import overlap as shapes_overlap
from .floorplan import (
    GEOMETRY_TOLERANCE_M,
    PRECAST_RECIPE,
    Recipe,
    Rect,
    Step,
    StorageSpot,
    bounding_rect,
    narrow_lanes,
    neighbours,
    overlapping_pairs,
    plan_case,
)
from .ifc_levels import describe, how_to_set, slabs_top_m, stated_levels, working_level
from .load import BUILTIN_CASE, CaseError, _did_you_mean, _read_toml, case_from_dict

# the package is installed from a checkout (it is not on a package index): the extra from there
INSTALL_HINT = "pip install -e '.[ifc]' in the checkout (make test installs it)"

# The overlay's defaults fit the built-in case: its crews (Table 3's seven), its storages
# (rebars and templates on the top edge, struts on the bottom edge) and its margins (6 m of
# open floor left and right of the components, 7 m above and below).
DEFAULT_OVERLAY: dict = {
    "plane": {"margin_x_m": 6.0, "margin_y_m": 7.0},
    # polygons: an element whose footprint is one polygon but no rectangle (notched,
    # trapezoidal, L-shaped) is imported as drawn (a component's outline); false: boxed,
    # refused below min_fill as before polygons
    "import": {"min_fill": 0.9, "neighbour_gap_m": 5.0, "check_storey": True,
               "polygons": True,
               # elements of these classes whose body lies wholly below the storey's level
               # carry the floor (beams and columns under the slabs, the walls of the storey
               # below): supports, not obstacles on the work plane (:func:`split_supports`)
               "supports": ["IfcBeam", "IfcColumn", "IfcWall", "IfcMember"],
               # slabs side by side with joints this narrow form a deck, walked on once
               # laid (:func:`deck_slabs`)
               "deck_joint_max_m": 0.1},
               # no "level_m": the storey's level comes from the model unless the overlay
               # gives one (``ifc_levels.working_level``)
    "crews": {"JCC": 1, "HIC": 1, "GC": 1, "RC": 2, "FC": 2},
    "crane": {"lift_time_s": 240.0, "assist_time_s": 180.0},
    # x_frac: where along the edge, -1 (left wall) to 1 (right wall)
    "storages": [
        {"id": "ST-rebars", "material": "rebars", "width_m": 6.0, "height_m": 3.0,
         "capacity": 3.0, "congestion_index_full": 0.5, "edge": "top", "x_frac": -4 / 9},
        {"id": "ST-templates", "material": "templates", "width_m": 6.0, "height_m": 3.0,
         "capacity": 80.0, "congestion_index_full": 0.5, "edge": "top", "x_frac": 4 / 9},
        {"id": "ST-struts", "material": "struts", "width_m": 5.0, "height_m": 3.0,
         "capacity": 12.0, "congestion_index_full": 0.6, "edge": "bottom", "x_frac": 0.0},
    ],
}
_OVERLAY_SECTIONS = {"plane", "import", "crews", "crane", "storages", "recipe", "case",
                     "simulation", "reaching_reward", "task_types", "crew_types", "materials"}
_OVERLAY_KEYS = {"plane": ("margin_x_m", "margin_y_m", "width_m", "height_m"),
                 "import": ("min_fill", "neighbour_gap_m", "check_storey", "polygons",
                            "supports",
                            "deck_joint_max_m", "level_m"),
                 "crane": ("lift_time_s", "assist_time_s")}
_STORAGE_KEYS = ("id", "material", "width_m", "height_m", "capacity", "congestion_index_full",
                 "edge", "x_frac")
TIME_LIMIT_S_PER_TASK = 1000.0  # as the generated layouts: at least this much per task


class IfcUnavailable(ImportError):
    """IfcOpenShell is not installed."""


def require_ifcopenshell():
    """The ``ifcopenshell`` module, or :class:`IfcUnavailable` saying how to install it."""
    try:
        import ifcopenshell
        import ifcopenshell.geom  # noqa: F401
        import ifcopenshell.util.element  # noqa: F401
    except ImportError as err:
        raise IfcUnavailable(f"reading and writing IFC needs IfcOpenShell ({err}); fix: "
                             f"{INSTALL_HINT}") from None
    return ifcopenshell


def open_model(path: str | Path):
    """An IFC model, or :class:`CaseError` naming the file and why it cannot be read."""
    ifcopenshell = require_ifcopenshell()
    path = Path(path)
    if not path.is_file():
        raise CaseError(str(path), ["cannot read the file (no such file); fix: check the path"])
    with path.open("rb") as f:
        head = f.read(64)
    if not head.lstrip().startswith(b"ISO-10303-21"):
        raise CaseError(path.name, ["is not an IFC file (an IFC-SPF file starts with "
                                    "'ISO-10303-21;'); fix: export the model as .ifc"])
    try:
        return ifcopenshell.open(str(path))
    except Exception as err:  # ifcopenshell raises its own error types, or RuntimeError
        raise CaseError(path.name, [f"cannot be read as IFC ({err}); fix: check the file in a "
                                    "BIM viewer and export it again"]) from None


# -- the overlay ------------------------------------------------------------------------------

@dataclass(frozen=True)
class Overlay:
    """What the IFC model does not say: crews, crane, storages, margins, the recipe, and
    the case's tables (task types, crew types, materials, simulation), resolved."""

    data: dict  # the merged overlay, defaults filled in
    recipe: Recipe
    base: dict  # the built-in case's tables, overridden by the overlay's
    source: str
    given: frozenset = frozenset()  # the sections the overlay file gave (the rest: defaults)

    def provenance(self) -> dict[str, str]:
        """Where each setting the model does not hold came from: "overlay FILE" for a section
        the overlay gave (merged over the defaults for plane, import and crane), "default"
        for the rest (DEFAULT_OVERLAY; the built-in case's tables; the precast recipe)."""
        return {section: (f"overlay {self.source}" if section in self.given else "default")
                for section in sorted(_OVERLAY_SECTIONS)}


def _recipe_from(data: dict | None, source: str, problems: list[str]) -> Recipe:
    if data is None:
        return PRECAST_RECIPE
    if not isinstance(data, dict) or not isinstance(data.get("chains"), dict) \
            or not isinstance(data.get("classes", {}), dict):
        problems.append("recipe: needs [recipe.classes] (IFC class = kind) and "
                        "[recipe.chains] (kind = [{type = ...}, ...]); fix: see docs/ifc.md")
        return PRECAST_RECIPE
    chains: dict[str, tuple[Step, ...]] = {}
    for kind, steps in data["chains"].items():
        if not isinstance(steps, list):
            problems.append(f"recipe.chains.{kind}: write a list of steps, e.g. "
                            '[{type = "JC"}, {type = "HI"}]')
            continue
        built = []
        for k, step in enumerate(steps):
            known = {"type", "work", "material_quantity", "after_neighbours"}
            if not isinstance(step, dict) or not isinstance(step.get("type"), str) \
                    or set(step) - known:
                problems.append(f"recipe.chains.{kind}[{k}]: a step is a table with type and "
                                "optionally work, material_quantity, after_neighbours; fix: "
                                'e.g. {type = "R", work = 0.5, after_neighbours = "HI"}')
                continue
            built.append(Step(step["type"], step.get("work"),
                              float(step.get("material_quantity", 0.0)),
                              step.get("after_neighbours")))
        chains[kind] = tuple(built)
    for key in set(data) - {"classes", "chains"}:
        problems.append(f"recipe.{key}: unknown field; fix: the recipe has classes and chains "
                        "(the neighbours' distance is import.neighbour_gap_m)")
    return Recipe(chains=chains, classes=dict(data.get("classes", PRECAST_RECIPE.classes)))


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def load_overlay(path: str | Path | None = None) -> Overlay:
    """The overlay TOML merged over :data:`DEFAULT_OVERLAY` and the built-in case's tables,
    checked: every problem reported together in one :class:`CaseError` naming the file."""
    source = Path(path).name if path is not None else "the default overlay"
    # read as a case file is: one wording for an unreadable file and a syntax error in both
    raw: dict = _read_toml(Path(path)) if path is not None else {}
    problems = [f"[{k}]: unknown section; fix: use one of "
                + ", ".join(sorted(_OVERLAY_SECTIONS)) for k in raw if k not in _OVERLAY_SECTIONS]
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in DEFAULT_OVERLAY.items()}
    for key in ("plane", "import", "crane"):
        if isinstance(raw.get(key), dict):
            data[key] = {**data[key], **raw[key]}
    for key in ("crews", "storages", "case"):
        if key in raw:
            data[key] = raw[key]
    base_toml = tomllib.loads(BUILTIN_CASE.read_text(encoding="utf-8"))
    base = {k: raw.get(k, base_toml[k]) for k in ("simulation", "reaching_reward", "task_types",
                                                   "crew_types", "materials")}
    recipe = _recipe_from(raw.get("recipe"), source, problems)
    gap = data["import"]["neighbour_gap_m"]
    if _is_number(gap):
        recipe = Recipe(recipe.chains, recipe.classes, float(gap))

    for section, value in data.items():
        if section == "storages":
            continue
        allowed = _OVERLAY_KEYS.get(section)
        if allowed is None:
            continue
        for key in value:
            if key not in allowed:
                problems.append(f"{section}.{key}: unknown field"
                                + _did_you_mean(key, list(allowed)))
            elif key in ("check_storey", "polygons"):
                if not isinstance(value[key], bool):
                    problems.append(f"{section}.{key} = {value[key]!r}: write true or false")
            elif key == "level_m":  # a height, below the model's origin too (a basement)
                if not _is_number(value[key]):
                    problems.append(f"{section}.{key} = {value[key]!r}: write the storey's "
                                    "level in metres, a number (e.g. 3.0, or -3.0 below the "
                                    "model's origin)")
            elif key == "supports":
                classes = value[key]
                if not isinstance(classes, list) or not all(
                        isinstance(c, str) and re.fullmatch(r"Ifc\w+", c) for c in classes):
                    problems.append(f"{section}.{key} = {classes!r}: write a list of IFC "
                                    "classes whose elements below the storey's level carry "
                                    'it, e.g. ["IfcBeam", "IfcColumn"], or [] for none')
            elif not _is_number(value[key]) or value[key] < 0:
                problems.append(f"{section}.{key} = {value[key]!r}: write a number of 0 or "
                                "more")
    if not isinstance(data["storages"], list):
        problems.append("storages: write [[storages]] entries; fix: see docs/ifc.md")
        data["storages"] = []
    for k, st in enumerate(data["storages"]):
        where = f"storages[{k}]"
        if not isinstance(st, dict):
            problems.append(f"{where}: write a table; fix: see docs/ifc.md")
            continue
        for key in ("id", "material", "width_m", "height_m", "capacity"):
            if key not in st:
                problems.append(f"{where}: {key} missing; fix: add {key} = ...")
        for key in st:
            if key not in _STORAGE_KEYS:
                problems.append(f"{where}: {key}: unknown field"
                                + _did_you_mean(key, list(_STORAGE_KEYS)))
        if st.get("edge", "top") not in ("top", "bottom"):
            problems.append(f'{where}: edge = {st["edge"]!r}; fix: write "top" or "bottom"')
        if not _is_number(st.get("x_frac", 0.0)) or not -1 <= st.get("x_frac", 0.0) <= 1:
            problems.append(f"{where}: x_frac = {st['x_frac']!r}; fix: a number from -1 (left "
                            "wall) to 1 (right wall)")
    if _is_number(data["import"]["min_fill"]) and not 0 <= data["import"]["min_fill"] <= 1:
        problems.append("import.min_fill: a share of the rectangle, from 0 to 1; fix: e.g. 0.9")
    crew_types = base["crew_types"] if isinstance(base["crew_types"], dict) else {}
    task_types = base["task_types"] if isinstance(base["task_types"], dict) else {}
    if not isinstance(data["crews"], dict):
        problems.append('crews: write a table of crew type = count, e.g. JCC = 1; fix: '
                        "see docs/ifc.md")
        data["crews"] = {}
    for name, count in data["crews"].items():
        if name not in crew_types:
            problems.append(f'crews.{name}: names unknown crew type "{name}"'
                            + _did_you_mean(name, list(crew_types)))
        if not isinstance(count, int) or isinstance(count, bool) or count < 0:
            problems.append(f"crews.{name} = {count!r}: write a whole number of crews")
    for kind, steps in recipe.chains.items():
        for k, step in enumerate(steps):
            for label, name in (("type", step.type), ("after_neighbours", step.after_neighbours)):
                if name is None:
                    continue
                if name not in task_types:
                    problems.append(f'recipe.chains.{kind}[{k}]: {label} names unknown task '
                                    f'type "{name}"' + _did_you_mean(name, list(task_types)))
                    continue
                crew_type = task_types[name].get("crew_type")
                if crew_type not in crew_types:
                    problems.append(f'recipe.chains.{kind}[{k}]: task type {name} needs crew '
                                    f'type "{crew_type}", which is not in [crew_types]'
                                    + _did_you_mean(str(crew_type), list(crew_types)))
    for cls, kind in recipe.classes.items():
        if not isinstance(kind, str) or not re.fullmatch(r"Ifc\w+(\.\w+)?", cls):
            problems.append(f'recipe.classes: {cls} = {kind!r}; fix: write an IFC class (or '
                            'Class.PREDEFINEDTYPE) = "kind", e.g. IfcBeam = "cast-in-place"')
    if problems:
        raise CaseError(source, problems)
    return Overlay(data=data, recipe=recipe, base=base, source=source,
                   given=frozenset(k for k in raw if k in _OVERLAY_SECTIONS))


# -- reading the storey ----------------------------------------------------------------------

@dataclass(frozen=True)
class Element:
    """An element of the storey that the recipe takes, with its plan footprint (metres,
    the model's world coordinates)."""

    guid: str
    ifc_class: str
    name: str
    kind: str
    rect: Rect | None  # the footprint's bounding rectangle; None: no body geometry
    fill: float  # footprint area / rectangle area
    z_m: tuple[float, float] | None = None  # the body's bottom and top (world z, metres)
    classes: tuple[str, ...] = ()  # its class and superclasses, most specific first
    parts_from: tuple[str, ...] = ()  # the classes of the parts its body came from, if any
    outline: tuple | None = None  # its footprint's corners when no rectangle (world, m)

    @property
    def label(self) -> str:
        return f'{self.ifc_class} "{self.name}" ({self.guid})'


def storey_names(model) -> list[str]:
    return [s.Name or s.GlobalId for s in model.by_type("IfcBuildingStorey")]


def find_storey(model, name: str, source: str):
    """The storey whose Name (or GlobalId) is ``name``; :class:`CaseError` listing them."""
    storeys = model.by_type("IfcBuildingStorey")
    found = [s for s in storeys if s.Name == name or s.GlobalId == name]
    listed = ", ".join(f'"{n}"' for n in storey_names(model)) or "none"
    if not found:
        close = _did_you_mean(name, storey_names(model))
        hint = close if close.startswith("; did") else ""
        raise CaseError(source, [f'has no storey "{name}"{hint}; fix: use one of its storeys: '
                                 f"{listed}"])
    if len(found) > 1:
        raise CaseError(source, [f'{len(found)} storeys are named "{name}"; fix: name it by '
                                 "GlobalId: " + ", ".join(s.GlobalId for s in found)])
    return found[0]


# A storey alone in its building has no storey levels to take its height from: it is taken
# as this high (its range: its level +- half of it).
NOMINAL_STOREY_HEIGHT_M = 4.0


@dataclass(frozen=True)
class StoreyRange:
    """Where the elements of a storey sit: the bottom of an element's body (world z, metres)
    lies from ``low_m`` up to (not including) ``high_m``, the levels halfway to the storeys
    below and above. With no storey below (above), the range reaches as far down (up) as it
    reaches up (down); a storey alone in its building spans its level +-
    ``NOMINAL_STOREY_HEIGHT_M`` / 2. An element outside sits nearer another storey's level
    than its own."""

    name: str
    level_m: float
    low_m: float
    high_m: float
    others: tuple[StoreyRange, ...] = ()  # the building's other storeys with a level
    route: str = "placement"  # where level_m came from (``ifc_levels.ROUTES``)

    @property
    def level(self) -> str:
        """"level 3.00 m from the storey's placement", for notes and refusals."""
        return describe(self.level_m, self.route)

    def holds(self, z_m: float) -> bool:
        return self.low_m - 1e-6 <= z_m < self.high_m - 1e-6

    def sits_on(self, z_m: float) -> StoreyRange | None:
        """The other storey whose range holds ``z_m``, if any."""
        return next((s for s in self.others if s.holds(z_m)), None)


def _stated_level(storey, scale: float) -> tuple[float | None, str]:
    """The level the model states for a storey, in metres, and its route: its Elevation,
    else its placement's world z (``ifc_levels.working_level`` without the overlay and the
    slabs); (None, "none"): neither."""
    return working_level(None, *stated_levels(storey, scale), None)


def storey_ranges(levels: Sequence[tuple[str, float]]) -> list[StoreyRange]:
    """The :class:`StoreyRange` of each storey of a building, from (name, level in metres);
    storeys at one level (within a millimetre) share a range."""
    distinct = sorted({round(lv, 3) for _, lv in levels})
    spans = {}
    for k, level in enumerate(distinct):
        down = (level - distinct[k - 1]) / 2 if k > 0 else None
        up = (distinct[k + 1] - level) / 2 if k + 1 < len(distinct) else None
        if down is None and up is None:
            down = up = NOMINAL_STOREY_HEIGHT_M / 2
        spans[level] = (level - (down if down is not None else up),
                        level + (up if up is not None else down))
    return [StoreyRange(name, lv, *spans[round(lv, 3)]) for name, lv in levels]


def storey_range(model, storey, level: tuple[float, str] | None = None
                 ) -> StoreyRange | None:
    """The storey's :class:`StoreyRange` among the storeys of its building (of the model when
    it is in none), with the others (each at the level the model states for it). ``level``:
    the storey's own level in metres and its route (``ifc_levels.working_level``), else the
    level the model states; None when it has none (neither an Elevation nor a placement)."""
    import ifcopenshell.util.element
    import ifcopenshell.util.unit

    scale = ifcopenshell.util.unit.calculate_unit_scale(model)
    level_m, route = level if level is not None else _stated_level(storey, scale)
    if level_m is None:
        return None
    parent = ifcopenshell.util.element.get_aggregate(storey)
    peers = ([p for p in ifcopenshell.util.element.get_parts(parent)
              if p.is_a("IfcBuildingStorey")] if parent is not None
             else model.by_type("IfcBuildingStorey"))
    peers = [p for p in peers if p != storey]
    with_level = [(storey, level_m)] + [(p, lv) for p in peers
                                        if (lv := _stated_level(p, scale)[0]) is not None]
    ranges = storey_ranges([(p.Name or p.GlobalId, lv) for p, lv in with_level])
    own = ranges[0]
    others = tuple(r for r in ranges[1:] if abs(r.level_m - own.level_m) > 1e-3)
    return StoreyRange(own.name, own.level_m, own.low_m, own.high_m, others, route)


def _class_chain(element) -> list[str]:
    """The element's class and its superclasses, most specific first."""
    from ifcopenshell import ifcopenshell_wrapper

    schema = element.is_a(True).split(".")[0]
    decl = ifcopenshell_wrapper.schema_by_name(schema).declaration_by_name(element.is_a())
    chain = []
    while decl is not None:
        chain.append(decl.name())
        decl = decl.supertype()
    return chain


def footprint(shapes) -> tuple[Rect | None, float]:
    """The plan footprint of tessellated shapes (one, or a sequence: an element's parts;
    world coordinates, metres): its bounding rectangle and the share of that rectangle the
    footprint fills (the union of the triangles' projections on the floor)."""
    rect, fill, _ = footprint_outline(shapes)
    return rect, fill


def footprint_outline(shapes) -> tuple[Rect | None, float, tuple | None]:
    """``footprint``'s rectangle and fill, and the footprint's projected outline: the union of
    the body's projected faces simplified within ``GEOMETRY_TOLERANCE_M``, as its corners
    (world, metres), when it is one polygon without holes that its rectangle does not fill
    (a notched, trapezoidal or L-shaped slab); None for a rectangle (or a footprint of
    several pieces or with holes: those are boxed, ``[import] min_fill``)."""
    import numpy as np
    import shapely

    shapes = shapes if isinstance(shapes, (list, tuple)) else [shapes]
    verts = [np.asarray(s.geometry.verts, dtype=float).reshape(-1, 3) for s in shapes]
    faces = [np.asarray(s.geometry.faces, dtype=int).reshape(-1, 3) for s in shapes]
    tris = [v[f][:, :, :2] for v, f in zip(verts, faces, strict=True) if len(f)]  # (n, 3, 2)
    verts = np.concatenate(verts) if verts else np.zeros((0, 3))
    if len(verts) == 0:
        return None, 0.0
    tris = np.concatenate(tris) if tris else np.zeros((0, 3, 2))
    cross = ((tris[:, 1, 0] - tris[:, 0, 0]) * (tris[:, 2, 1] - tris[:, 0, 1])
             - (tris[:, 1, 1] - tris[:, 0, 1]) * (tris[:, 2, 0] - tris[:, 0, 0]))
    tris = tris[np.abs(cross) > 1e-9]  # faces seen edge-on from above add no area
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    rect = Rect(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
    if len(tris) == 0 or rect.area <= 0:
        return rect, 0.0, None
    # the faces' union, its slivers between triangles closed within the tolerance
    union = shapely.union_all(shapely.polygons(tris))
    fill = min(1.0, union.area / rect.area)
    shape = union.buffer(GEOMETRY_TOLERANCE_M / 2, join_style="mitre").buffer(
        -GEOMETRY_TOLERANCE_M / 2, join_style="mitre").simplify(GEOMETRY_TOLERANCE_M)
    if fill >= 0.999 or shape.geom_type != "Polygon" or shape.interiors:
        return rect, fill, None
    return rect, fill, tuple(shape.exterior.coords[:-1])


def _body_shapes(element, settings) -> tuple[list, list]:
    """The tessellated body of an element (world coordinates, metres: IfcOpenShell converts
    the model's length unit, and takes the body in whatever context it is modelled, 'Body' or
    'Plan'), and the parts it came from. An element without a body of its own (no
    representation, or only an axis or a box) takes its parts' bodies: the elements aggregated
    to it (IfcRelAggregates), as precast detailing tools write a slab whose body sits on a
    proxy; a part without a body takes its own parts'."""
    import ifcopenshell.geom
    import ifcopenshell.util.element

    if element.Representation is not None:
        try:
            shape = ifcopenshell.geom.create_shape(settings, element)
        except RuntimeError:  # no body: an axis, a bounding box, nothing to tessellate
            shape = None
        if shape is not None and len(shape.geometry.verts):
            return [shape], []
    shapes, parts = [], []
    for part in ifcopenshell.util.element.get_parts(element) or []:
        if not part.is_a("IfcElement"):
            continue
        got, below = _body_shapes(part, settings)
        if got:
            shapes += got
            parts += [part, *below]
    return shapes, parts


def storey_elements(model, storey, recipe: Recipe) -> tuple[list[Element], dict[str, int]]:
    """The storey's elements that the recipe takes (contained or aggregated, in file order)
    with their footprints, and a count of the element classes it skipped. An element without
    a body of its own takes its footprint from its parts (:func:`_body_shapes`); those parts
    are neither components nor skipped."""
    import ifcopenshell.geom
    import ifcopenshell.util.element

    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    taken, not_taken = [], []
    decomposed = ifcopenshell.util.element.get_decomposition(storey)
    for element in sorted(decomposed, key=lambda e: e.id()):
        if not element.is_a("IfcElement"):
            continue
        chain = _class_chain(element)
        kind = recipe.kind_of(chain, ifcopenshell.util.element.get_predefined_type(element))
        if kind is None:
            not_taken.append(element)
            continue
        shapes, parts = _body_shapes(element, settings)
        taken.append((element, chain, kind, shapes, parts))
    in_others = {part.id(): part for *_, parts in taken for part in parts}
    elements = []
    for element, chain, kind, shapes, parts in taken:
        if element.id() in in_others:
            continue  # a part of an element taken whole
        rect, fill, z, outline = None, 0.0, None, None
        if shapes:
            rect, fill, outline = footprint_outline(shapes)
            heights = [h for s in shapes for h in s.geometry.verts[2::3]]
            z = (min(heights), max(heights))
        elements.append(Element(element.GlobalId, element.is_a(), (element.Name or "").strip(),
                                kind, rect, fill, z, tuple(chain),
                                tuple(sorted({p.is_a() for p in parts})), outline))
    skipped: dict[str, int] = {}
    for element in not_taken:
        if element.id() not in in_others:
            skipped[element.is_a()] = skipped.get(element.is_a(), 0) + 1
    return elements, skipped


def _component_ids(elements: Sequence[Element]) -> list[str]:
    """Each element's Name where it is unique among the elements, else ``Slab-3``."""
    counts: dict[str, int] = {}
    for e in elements:
        counts[e.name] = counts.get(e.name, 0) + 1
    taken = {e.name for e in elements if e.name and counts[e.name] == 1}
    ids, numbered = [], {}
    for e in elements:
        if e.name and counts[e.name] == 1:
            ids.append(e.name)
            continue
        stem = e.ifc_class.removeprefix("Ifc")
        while True:
            numbered[stem] = numbered.get(stem, 0) + 1
            candidate = f"{stem}-{numbered[stem]}"
            if candidate not in taken:
                break
        taken.add(candidate)
        ids.append(candidate)
    return ids


# -- the model's 4D schedule -----------------------------------------------------------------

@dataclass
class ModelSchedule:
    """The 4D schedule the model carries for the storey's elements: per IfcTask (by GlobalId)
    its name and the components it builds, and the sequences between such tasks."""

    tasks: dict[str, tuple[str, list[str], str | None]] = field(default_factory=dict)
    sequences: list[tuple[str, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def task_code(task) -> str:
    """A task's Identification (IFC4), or TaskId (IFC2X3), or ""."""
    return getattr(task, "Identification", None) or getattr(task, "TaskId", None) or ""


def _task_label(task) -> str:
    return f'IfcTask "{task.Name or task_code(task)}" ({task.GlobalId})'


def model_schedule(model, component_of: dict[str, str], recipe: Recipe) -> ModelSchedule:
    """The IfcTasks that build the components' elements (the task assigned to the element,
    IfcRelAssignsToProduct, or the element to the task, IfcRelAssignsToProcess) and the
    IfcRelSequence among them.

    A task whose Identification or Name holds one of the recipe's task types as a word
    (e.g. "HI S-1") stands for that task type only; None: for the whole chain."""
    types = recipe.task_types()
    schedule = ModelSchedule()
    # A task builds an element: the task assigned to the element (IfcRelAssignsToProduct, as
    # ifcopenshell.api and cmdp-simulate --ifc write it), or the element assigned to the task
    # as what it operates on (IfcRelAssignsToProcess, as some 4D tools write it)
    links = [(rel.RelatingProduct, task) for rel in model.by_type("IfcRelAssignsToProduct")
             for task in rel.RelatedObjects]
    links += [(product, rel.RelatingProcess) for rel in model.by_type("IfcRelAssignsToProcess")
              for product in rel.RelatedObjects]
    for product, task in links:
        comp = component_of.get(getattr(product, "GlobalId", None))
        if comp is None or not task.is_a("IfcTask"):
            continue
        words = re.split(r"[^A-Za-z0-9]+", f"{task_code(task)} {task.Name or ''}")
        step = next((w for w in words if w in types), None)
        label, comps, _ = schedule.tasks.get(task.GlobalId, (_task_label(task), [], step))
        if comp not in comps:
            schedule.tasks[task.GlobalId] = (label, [*comps, comp], step)
    for rel in model.by_type("IfcRelSequence"):
        a, b = rel.RelatingProcess.GlobalId, rel.RelatedProcess.GlobalId
        if a not in schedule.tasks or b not in schedule.tasks:
            continue
        kind = getattr(rel, "SequenceType", None) or "FINISH_START"
        if kind != "FINISH_START":
            schedule.notes.append(f"IfcRelSequence {rel.GlobalId} {schedule.tasks[a][0]} -> "
                                  f"{schedule.tasks[b][0]} is {kind}; read as FINISH_START")
        lag = getattr(rel, "TimeLag", None)
        if lag is not None and lag != 0:  # IFC2X3: a number (always given); IFC4: IfcLagTime
            schedule.notes.append(f"IfcRelSequence {rel.GlobalId}: its time lag is ignored")
        schedule.sequences.append((a, b))
    return schedule


def _schedule_cycle(schedule: ModelSchedule) -> list[str] | None:
    preds: dict[str, list[str]] = {t: [] for t in schedule.tasks}
    for a, b in schedule.sequences:
        preds[b].append(a)
    try:
        graphlib.TopologicalSorter(preds).prepare()
    except graphlib.CycleError as err:
        return list(err.args[1])
    return None


def _sequence_predecessors(schedule: ModelSchedule, chains: dict[str, list[str]],
                           task_types: dict[str, str]) -> dict[str, list[str]]:
    """Case task -> the case tasks it waits for, from the model's sequences."""

    def tasks_of(guid: str, end: bool) -> list[str]:
        _, comps, step = schedule.tasks[guid]
        out = []
        for comp in comps:
            chain = chains.get(comp, [])
            if step is not None:
                out += [t for t in chain if task_types[t] == step]
            elif chain:
                out.append(chain[-1] if end else chain[0])
        return out

    preds: dict[str, list[str]] = {}
    for a, b in schedule.sequences:
        for later in tasks_of(b, end=False):
            for earlier in tasks_of(a, end=True):
                if earlier != later and earlier not in preds.setdefault(later, []):
                    preds[later].append(earlier)
    return preds


# -- the case --------------------------------------------------------------------------------

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


def is_support(e: Element, storey: StoreyRange | None, classes: Sequence[str]) -> bool:
    """Whether an element carries the storey's floor rather than stands on it: of one of
    ``classes`` (or a subclass), its body wholly below the storey's working level, the
    storey's level (its top at most ``GEOMETRY_TOLERANCE_M`` above), and reaching up into the
    storey's range (its top above ``storey.low_m``: a beam under the slabs, a column up to a
    slab's corner, a wall of the storey below; an element wholly in the storey below is
    misplaced, and reported as such). None: the storey has no level, so nothing is a
    support."""
    if storey is None or e.z_m is None or not any(c in classes for c in e.classes):
        return False
    top = e.z_m[1]
    return storey.low_m - GEOMETRY_TOLERANCE_M <= top <= storey.level_m + GEOMETRY_TOLERANCE_M


def split_supports(elements: Sequence[Element], storey: StoreyRange | None,
                   classes: Sequence[str]) -> tuple[list[Element], list[Element]]:
    """The storey's elements as (obstacles on the work plane, supports under it): what
    blocks walking is decided by elevation against the storey's level (:func:`is_support`),
    for the classes the overlay names (``[import] supports``)."""
    carries = [is_support(e, storey, classes) for e in elements]
    return ([e for e, c in zip(elements, carries, strict=True) if not c],
            [e for e, c in zip(elements, carries, strict=True) if c])


def deck_slabs(elements: Sequence[Element], joint_max_m: float) -> set[int]:
    """The indices of the slabs (``IfcSlab`` and its subclasses) that lie side by side with
    another slab (``Rect.side_gap``) with a joint of at most ``joint_max_m`` between them:
    a wide-slab or hollow-core deck, which crews walk on once laid (``Component.deck``).
    Slabs standing apart (cast-in-place joints between them, as on the built-in floor) are
    none. E.g. two 3 x 1.2 m slabs 80 mm apart along x, joint_max_m 0.1: both."""
    slabs = [k for k, e in enumerate(elements) if "IfcSlab" in e.classes and e.rect is not None]
    out = set()
    for n, a in enumerate(slabs):
        for b in slabs[n + 1:]:
            gap = elements[a].rect.side_gap(elements[b].rect)
            if gap is not None and gap <= joint_max_m + GEOMETRY_TOLERANCE_M:
                out.update((a, b))
    return out


def build_case(elements: Sequence[Element], overlay: Overlay, schedule: ModelSchedule | None,
               name: str, description: str, ids: Sequence[str], source: str,
               storey: StoreyRange | None = None) -> tuple[dict, list[str], str]:
    """The case data of a storey's elements (footprints checked; each element's height
    against ``storey``'s range unless the overlay's ``import.check_storey`` is false), the
    notes, and where the precedences came from ("recipe" or "model")."""
    problems, notes = [], []
    min_fill = float(overlay.data["import"]["min_fill"])
    polygons = overlay.data["import"]["polygons"] is True
    drawn = {k for k, e in enumerate(elements) if polygons and e.outline is not None}
    check_storey = storey is not None and overlay.data["import"]["check_storey"]
    for e in elements:
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
        elif e.outline is not None and polygons:
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
    rects = [e.rect for e in elements]
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
    recipe = overlay.recipe
    with_tasks = [k for k, e in enumerate(elements) if recipe.chains.get(e.kind)]
    use_model = schedule is not None and bool(schedule.sequences)
    ends = {} if use_model else {
        ids[k]: [ids[j] for j in neighbours(rects, k, with_tasks, recipe.neighbour_gap_m)]
        for k in with_tasks}
    # Crews only of the types that have work here: an idle crew type would wait all floor and
    # become an IfcCrewResource with nothing to do in the 4D model.
    left_out = crews_left_out(elements, overlay)
    crews = [(f"{ct}-{k + 1}", ct) for ct, n in overlay.data["crews"].items()
             if ct not in left_out for k in range(n)]
    if left_out:
        notes.append("no work for crew type(s) "
                     + ", ".join(f"{ct} ({n} crew{'s' if n > 1 else ''})"
                                 for ct, n in left_out.items())
                     + " on this storey: left out of the case")
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
    if use_model:
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
        notes += schedule.notes
    return data, notes, "model" if use_model else "recipe"


def _working_level(model, storey, elements: Sequence[Element], overlay: Overlay
                   ) -> tuple[StoreyRange | None, list[str]]:
    """The storey's range about its working level (``ifc_levels.working_level``: the
    overlay's ``[import] level_m``, its Elevation, its placement, its slabs' tops), and the
    notes that state a level the model does not (the slabs' tops, the overlay's) or a model
    that states two."""
    import ifcopenshell.util.unit

    scale = ifcopenshell.util.unit.calculate_unit_scale(model)
    elevation_m, placement_m = stated_levels(storey, scale)
    tops = slabs_top_m((e.z_m[1], e.rect.area) for e in elements
                       if "IfcSlab" in e.classes and e.z_m is not None and e.rect is not None)
    level_m, route = working_level(overlay.data["import"].get("level_m"), elevation_m,
                                   placement_m, tops)
    span = storey_range(model, storey, (level_m, route))
    if span is None:
        return None, []
    name = f'storey "{storey.Name or storey.GlobalId}"'
    stated = [f"its {what} says {m:.2f} m" for what, m in
              (("Elevation", elevation_m), ("placement", placement_m))
              if m is not None and abs(m - level_m) > GEOMETRY_TOLERANCE_M]
    if route == "slabs":
        return span, [f"{name}: {span.level}: supports lie below it and its elements' "
                      "heights are checked against it; if that is not the storey's level, "
                      f"{how_to_set(route)}"]
    if route == "overlay":
        return span, [f"{name}: {span.level}" + (f" ({', '.join(stated)}; the overlay's "
                                                  "is taken)" if stated else "")]
    if stated:  # an Elevation and a placement that disagree: the Elevation is taken
        return span, [f"{name}: {span.level} ({stated[0]}; the Elevation is taken); if the "
                      f"storey is at {placement_m:.2f} m, {how_to_set(route)}"]
    return span, []


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
