"""The storey of the IFC import: found by name, its range about its working level, and which of
its elements carry its floor or are walked on once laid.

An element sits on its storey when the bottom of its body lies in the storey's range, from
halfway down to the storey below to halfway up to the one above (:class:`StoreyRange`). What
blocks walking is decided by elevation: elements of the ``[import] supports`` classes whose
body lies wholly below the storey's working level (beams and columns under the slabs, walls
of the storey below) carry the floor and are no components (:func:`split_supports`). That
level comes from the overlay's ``[import] level_m``, else the storey's Elevation, its
placement or its slabs' tops (``ifc_levels.working_level``, :func:`_working_level`); the
notes and every refusal that depends on it name it and its route. Slabs side by side with
joints of at most ``[import] deck_joint_max_m`` form a deck, walked on once laid
(:func:`deck_slabs`).

Apart from the elements' footprints (``ifc_model``) and the case (``ifc_import``): these are
the rules of heights, the storey's and its elements'. IfcOpenShell is imported only when a
function here is called.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from .floorplan import GEOMETRY_TOLERANCE_M
from .ifc_levels import describe, how_to_set, slabs_top_m, stated_levels, working_level
from .ifc_model import Element
from .ifc_overlay import Overlay
from .load import CaseError, _did_you_mean


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
