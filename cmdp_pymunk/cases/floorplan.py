"""A floor plan as rectangles, the task recipes that give it tasks, and the plan -> case builder.

The precast floor's task chains (JC -> HI -> G on a precast component, R -> F on a
cast-in-place joint, each R waiting for the installation HI of the components the joint
connects) are data here, a :class:`Recipe`. :func:`plan_case` turns components and a recipe
into case data, placing crews, storages, crane and outlet by one set of rules, so that the
built-in case's tool (``tools/make_precast_floor.py``), the layout generator (``layouts``)
and the IFC importer (``ifc``) build floors the same way. A recipe says which component kinds
(and, for IFC, which element classes) get which chain of task steps, and which step waits for
a step on the neighbours (the components a joint connects). The case check (``case``) uses
:class:`Rect` for its overlaps.

Geometry: a :class:`Rect` is an axis-aligned rectangle in metres, ``x0 < x1`` and ``y0 < y1``;
two rectangles overlap when their interiors meet by more than :data:`GEOMETRY_TOLERANCE_M`
along both axes (touching edges, within the tolerance, do not overlap).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

# One geometric tolerance for the IFC importer and the case check: rectangles that meet by no
# more than this only touch (a millimetre of modelling noise in a BIM model, or the 1e-15 m
# that centring a floor on the origin adds to a shared edge).
GEOMETRY_TOLERANCE_M = 0.001


class Rect(NamedTuple):
    """An axis-aligned rectangle ``[x0, x1] x [y0, y1]`` in metres."""

    x0: float
    y0: float
    x1: float
    y1: float

    @classmethod
    def centred(cls, x: float, y: float, width: float, height: float) -> Rect:
        """The rectangle of a case entry: centre ``(x, y)``, ``width`` along x."""
        return cls(x - width / 2, y - height / 2, x + width / 2, y + height / 2)

    @property
    def centre(self) -> tuple[float, float]:
        return (self.x0 + self.x1) / 2, (self.y0 + self.y1) / 2

    @property
    def size(self) -> tuple[float, float]:
        return self.x1 - self.x0, self.y1 - self.y0

    @property
    def area(self) -> float:
        return (self.x1 - self.x0) * (self.y1 - self.y0)

    def overlap(self, other: Rect) -> tuple[float, float]:
        """The size (along x, along y) of the two rectangles' intersection, in metres; a
        side of 0 or less: they touch, or lie that far apart, along that axis.

        E.g. (0, 0, 2, 2) and (1.995, 1, 4, 3): 0.005 x 1 m.
        """
        return (min(self.x1, other.x1) - max(self.x0, other.x0),
                min(self.y1, other.y1) - max(self.y0, other.y0))

    def overlaps(self, other: Rect, tolerance_m: float = GEOMETRY_TOLERANCE_M) -> bool:
        """Whether the interiors meet by more than ``tolerance_m`` along both axes (shared
        edges and corners, within the tolerance, are not an overlap)."""
        w, h = self.overlap(other)
        return w > tolerance_m and h > tolerance_m

    def side_gap(self, other: Rect) -> float | None:
        """The gap to ``other`` when the two lie side by side: their projections on one axis
        overlap (by more than a touch, :data:`GEOMETRY_TOLERANCE_M`) and they are apart, or
        touching (within the tolerance: a gap of 0), along the other axis. None when they are
        diagonal to each other or overlap.

        E.g. (0, 0, 2, 2) and (5, 1, 6, 3): y projections overlap on (1, 2), gap along x 3.
        """
        tol = GEOMETRY_TOLERANCE_M
        share_x, share_y = self.overlap(other)
        gap_x = max(other.x0 - self.x1, self.x0 - other.x1)
        gap_y = max(other.y0 - self.y1, self.y0 - other.y1)
        if share_y > tol and gap_x >= -tol:
            return max(gap_x, 0.0)
        if share_x > tol and gap_y >= -tol:
            return max(gap_y, 0.0)
        return None


def bounding_rect(rects: Sequence[Rect]) -> Rect:
    """The smallest rectangle holding every one of ``rects`` (at least one)."""
    return Rect(min(r.x0 for r in rects), min(r.y0 for r in rects),
                max(r.x1 for r in rects), max(r.y1 for r in rects))


def overlapping_pairs(rects: Sequence[Rect]) -> list[tuple[int, int]]:
    """Index pairs ``(i, j)``, ``i < j``, of rectangles that overlap (:meth:`Rect.overlaps`,
    beyond :data:`GEOMETRY_TOLERANCE_M`)."""
    return [(i, j) for i in range(len(rects)) for j in range(i + 1, len(rects))
            if rects[i].overlaps(rects[j])]


def neighbours(rects: Sequence[Rect], of: int, among: Sequence[int], max_gap_m: float
               ) -> list[int]:
    """The rectangles of ``among`` beside rectangle ``of`` (``Rect.side_gap``) no more than
    ``max_gap_m`` away, in reading order (top row first, then left to right), so that a
    joint's two ends come out as (left, right) or (top, bottom)."""
    near = [k for k in among if k != of
            and (gap := rects[of].side_gap(rects[k])) is not None and gap <= max_gap_m]
    return sorted(near, key=lambda k: (-rects[k].centre[1], rects[k].centre[0]))


def narrow_lanes(rects: Sequence[Rect], min_width_m: float) -> list[tuple[int, int, float]]:
    """Pairs ``(i, j, gap)`` of rectangles side by side with an open lane between them
    narrower than ``min_width_m`` (touching ones leave no lane). A crew wider than a lane
    cannot pass it: on the generated layouts, 2 m lanes wedged 2.5 m crews for hours."""
    out = []
    for i in range(len(rects)):
        for j in range(i + 1, len(rects)):
            gap = rects[i].side_gap(rects[j])
            # a gap within the tolerance is rounding (centring a floor), not a lane
            if gap is None or not GEOMETRY_TOLERANCE_M < gap < min_width_m:
                continue
            lane = lane_between(rects[i], rects[j])
            if any(k not in (i, j) and lane.overlaps(r) for k, r in enumerate(rects)):
                continue  # a third rectangle stands between them: no lane there
            out.append((i, j, gap))
    return out


def lane_between(a: Rect, b: Rect) -> Rect:
    """The open strip between two rectangles side by side (``side_gap`` not None): across the
    gap, along the span their projections share. E.g. (0, 0, 2, 2) and (5, 1, 6, 3):
    (2, 1, 5, 2)."""
    share_x, share_y = a.overlap(b)
    if share_y >= share_x:  # side by side along x
        return Rect(min(a.x1, b.x1), max(a.y0, b.y0), max(a.x0, b.x0), min(a.y1, b.y1))
    return Rect(max(a.x0, b.x0), min(a.y1, b.y1), min(a.x1, b.x1), max(a.y0, b.y0))


# -- recipes ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Step:
    """One task of a chain: its task type, work (None: the default 1 task) and material,
    and optionally the task type on the neighbours it waits for (``after_neighbours``)."""

    type: str
    work: float | None = None
    material_quantity: float = 0.0
    after_neighbours: str | None = None


@dataclass(frozen=True)
class Recipe:
    """Which component kind gets which chain of steps (each step waits for the one before),
    and, for the importer, which IFC class (and predefined type) is which kind."""

    chains: Mapping[str, tuple[Step, ...]]
    classes: Mapping[str, str] = field(default_factory=dict)  # "IfcSlab" or "IfcSlab.FLOOR"
    neighbour_gap_m: float = 5.0  # how far apart a joint and the components it connects lie

    def kind_of(self, ifc_class_chain: Sequence[str], predefined_type: str | None) -> str | None:
        """The kind of an element of class ``ifc_class_chain[0]`` (its superclasses after it),
        None when the recipe takes no element of that class. ``Class.TYPE`` rules go first."""
        for cls in ifc_class_chain:
            if predefined_type and f"{cls}.{predefined_type}" in self.classes:
                return self.classes[f"{cls}.{predefined_type}"]
            if cls in self.classes:
                return self.classes[cls]
        return None

    def task_types(self) -> list[str]:
        """Every task type the recipe names, in the order they first appear."""
        names = [s.type for chain in self.chains.values() for s in chain]
        names += [s.after_neighbours for chain in self.chains.values() for s in chain
                  if s.after_neighbours]
        return list(dict.fromkeys(names))


# The precast floor of the paper's case study (section 5, Table 2): quantities as in the
# built-in case (docs/case-study.md): a strut set per installed component, 0.5 m3 of rebar and
# 12 m2 of formwork per joint.
REBAR_M3_PER_JOINT = 0.5
FORMWORK_M2_PER_JOINT = 12.0
STRUT_SETS_PER_PRECAST = 1.0
PRECAST_RECIPE = Recipe(
    chains={
        "precast": (Step("JC"), Step("HI", material_quantity=STRUT_SETS_PER_PRECAST),
                    Step("G")),
        "cast-in-place": (Step("R", REBAR_M3_PER_JOINT, REBAR_M3_PER_JOINT,
                               after_neighbours="HI"),
                          Step("F", FORMWORK_M2_PER_JOINT, FORMWORK_M2_PER_JOINT)),
    },
    # Precast elements are installed (JC -> HI -> G); beams are cast in place between them.
    classes={"IfcSlab": "precast", "IfcColumn": "precast", "IfcWall": "precast",
             "IfcMember": "precast", "IfcBeam": "cast-in-place"},
)


def task_id(step_type: str, component: str) -> str:
    return f"{step_type}-{component}"


def build_tasks(components: Sequence[tuple[str, str]], recipe: Recipe,
                ends: Mapping[str, Sequence[str]]) -> list[dict]:
    """The tasks of a floor as case entries, in component order, each component's chain in
    order.

    Args:
        components: ``(id, kind)`` of every component; kinds without a chain get no tasks.
        recipe: the chains.
        ends: per component, the components it connects (a joint's neighbours); a step with
            ``after_neighbours`` waits for that task type on each of them that has it.

    Returns:
        dicts with ``id``, ``type``, ``component``, then ``work`` and ``material_quantity``
        only when the step gives them, and ``predecessors`` only when there are some.
    """
    has = {task_id(s.type, cid) for cid, kind in components for s in recipe.chains.get(kind, ())}
    tasks = []
    for cid, kind in components:
        before: str | None = None
        for step in recipe.chains.get(kind, ()):
            preds = [before] if before else []
            if step.after_neighbours:
                preds += [t for end in ends.get(cid, ())
                          if (t := task_id(step.after_neighbours, end)) in has]
            task: dict = {"id": task_id(step.type, cid), "type": step.type, "component": cid}
            if step.work is not None:
                task["work"] = step.work
            if step.material_quantity:
                task["material_quantity"] = step.material_quantity
            if preds:
                task["predecessors"] = preds
            tasks.append(task)
            before = task["id"]
    return tasks


# -- the site around the components, and the whole case ---------------------------------------

CREW_INSET_M = 2.5  # crews start this far from the left wall
CREW_SPACING_M = 3.0  # and this far apart (closer on a low plane)
EDGE_INSET_M = 1.0  # storages stand this far from the top or bottom wall
CRANE_INSET_M = 1.5  # the crane stands at the top wall's middle, this far in
OUTLET_INSET_M = 1.0  # the outlet: the left wall's middle, this far in


@dataclass(frozen=True)
class StorageSpot:
    """A storage of a floor plan: a ``width_m`` x ``height_m`` rectangle at ``x_m`` along the
    top (``edge`` +1) or bottom (-1) wall, ``EDGE_INSET_M`` from it."""

    id: str
    material: str
    width_m: float
    height_m: float
    capacity: float
    congestion_index_full: float
    edge: int
    x_m: float


def plan_case(*, name: str, description: str, half_width_m: float, half_height_m: float,
              base: Mapping, crane_times: Mapping, crews: Sequence[tuple[str, str]],
              storages: Sequence[StorageSpot], components: Sequence[dict], recipe: Recipe,
              ends: Mapping[str, Sequence[str]], time_limit_s_per_task: float) -> dict:
    """A floor plan as case data: the plane ``2 half_width_m x 2 half_height_m`` centred on
    the origin, the outlet at the left wall's middle, the crane at the top wall's middle,
    crews in a column near the left wall, storages along the top and bottom walls, the
    components (case entries, in order) and their tasks from ``recipe`` (``build_tasks``).

    ``base`` gives the tables a plan does not change: ``simulation`` (its ``max_time_s``
    raised to ``time_limit_s_per_task`` per task if lower), ``reaching_reward``,
    ``task_types``, ``materials``, ``crew_types``. ``crane_times``: the crane's
    ``lift_time_s`` and ``assist_time_s``. Used by the generated layouts (``layouts``), the
    built-in case's tool and the IFC importer (``ifc``).
    """
    half_w, half_h = half_width_m, half_height_m
    tasks = build_tasks([(c["id"], c["kind"]) for c in components], recipe, ends)
    spread = min(CREW_SPACING_M, (2 * half_h - 6.0) / max(1, len(crews) - 1))
    crew_rows = [{"id": cid, "type": ctype, "start_x_m": -half_w + CREW_INSET_M,
                  "start_y_m": round((k - (len(crews) - 1) / 2) * spread, 3),
                  "start_heading_deg": 0.0} for k, (cid, ctype) in enumerate(crews)]
    storage_rows = [{"id": s.id, "material": s.material, "x_m": s.x_m,
                     "y_m": s.edge * (half_h - EDGE_INSET_M - s.height_m / 2),
                     "width_m": s.width_m, "height_m": s.height_m, "capacity": s.capacity,
                     "congestion_index_full": s.congestion_index_full} for s in storages]
    simulation = dict(base["simulation"])
    simulation["max_time_s"] = max(simulation["max_time_s"], time_limit_s_per_task * len(tasks))
    return {
        "case": {"name": name, "description": description},
        "plane": {"width_m": 2 * half_w, "height_m": 2 * half_h,
                  "outlet_x_m": -half_w + OUTLET_INSET_M, "outlet_y_m": 0.0,
                  "outlet_radius_m": 1.5},
        "simulation": simulation,
        "reaching_reward": base["reaching_reward"],
        "crane": {"x_m": 0.0, "y_m": half_h - CRANE_INSET_M, **crane_times},
        "task_types": base["task_types"], "materials": base["materials"],
        "crew_types": base["crew_types"],
        "crews": crew_rows, "storages": storage_rows, "components": list(components),
        "tasks": tasks,
    }
