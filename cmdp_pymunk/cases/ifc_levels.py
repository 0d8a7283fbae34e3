"""A storey's working level for the IFC import (``cases.ifc_import``): the height of the plane
the crews work on, against which supports (below it) and obstacles (on it) are told apart and
the storey's range is drawn.

The level comes by one of these routes (:func:`working_level`), the first that gives one:

1. ``[import] level_m`` in the overlay: the user's word, over anything the model says (a
   refusal's fix names it, so it must take effect whatever the model holds);
2. the storey's ``Elevation`` (IfcBuildingStorey, the model's length unit);
3. its placement: the world z of its ``ObjectPlacement``, composed through the placements
   it is relative to (the building's, the site's);
4. the tops of the storey's slabs (the recipe's ``IfcSlab`` elements and subclasses), where
   the crews walk: the top that the largest share of slab area reaches, to the millimetre.
   An inference, so the import's notes say so.

None of them: the storey has no level; nothing is a support and heights are not checked.
The route is returned beside the level so that notes and refusals can say where it came
from ("level 3.00 m from the storey's placement") and how to set it (:func:`how_to_set`).

IfcOpenShell is imported only by :func:`stated_levels`.
"""

from __future__ import annotations

from collections.abc import Iterable

# route -> how a message names it ("level 3.00 m from <this>")
ROUTES = {
    "overlay": "the overlay's [import] level_m",
    "elevation": "the storey's Elevation",
    "placement": "the storey's placement",
    "slabs": "the slabs' tops (the storey has neither an Elevation nor a placement)",
    "none": "",
}


def working_level(overlay_m: float | None, elevation_m: float | None,
                  placement_m: float | None, slab_tops_m: float | None
                  ) -> tuple[float | None, str]:
    """The storey's working level in metres and the route it came by (a key of
    :data:`ROUTES`): the overlay's ``[import] level_m``, else the storey's Elevation, else
    its placement's world z, else the slabs' tops (:func:`slabs_top_m`); (None, "none") when
    none of them is known. E.g. (None, 3.0, 0.0, 0.3) -> (3.0, "elevation"): a storey whose
    placement stayed at 0 while its Elevation says 3 m is at 3 m."""
    for route, level in (("overlay", overlay_m), ("elevation", elevation_m),
                         ("placement", placement_m), ("slabs", slab_tops_m)):
        if level is not None:
            return float(level), route
    return None, "none"


def slabs_top_m(slabs: Iterable[tuple[float, float]]) -> float | None:
    """The top most of the slabs' plan area reaches, in metres: from (top z in metres, plan
    area in m2) per slab, the top (to the millimetre) with the largest summed area, the
    higher on a tie; None: no slabs. E.g. tops 0.30 (two slabs of 18 m2) and 0.25 (one of
    30 m2, a recessed bay) -> 0.30: 36 m2 against 30."""
    area_at: dict[float, float] = {}
    for top, area in slabs:
        key = round(top, 3) + 0.0
        area_at[key] = area_at.get(key, 0.0) + area
    if not area_at:
        return None
    return max(area_at, key=lambda top: (area_at[top], top))


def describe(level_m: float | None, route: str) -> str:
    """"level 3.00 m from the storey's placement"; "no level (neither an Elevation nor a
    placement, no slabs, no [import] level_m)" for route "none"."""
    if level_m is None:
        return ("no level (neither an Elevation nor a placement, no slabs to take it from, "
                "no [import] level_m in the overlay)")
    return f"level {level_m:.2f} m from {ROUTES[route]}"


def how_to_set(route: str) -> str:
    """How to give the storey another level, by the route its level came by."""
    overlay = "set [import] level_m = ... (metres) in the overlay"
    if route == "overlay":
        return "change [import] level_m in the overlay"
    if route == "elevation":
        return f"correct the storey's Elevation in the model, or {overlay}"
    return f"{overlay}, or give the storey an Elevation in the model"


def stated_levels(storey, scale: float) -> tuple[float | None, float | None]:
    """What the model states of a storey's level, in metres: (its Elevation, its placement's
    world z composed through relative placements), each None where absent. ``scale``: metres
    per model length unit."""
    import ifcopenshell.util.placement

    elevation = float(storey.Elevation) * scale if storey.Elevation is not None else None
    placement = None
    if storey.ObjectPlacement is not None and storey.ObjectPlacement.is_a("IfcLocalPlacement"):
        matrix = ifcopenshell.util.placement.get_local_placement(storey.ObjectPlacement)
        placement = float(matrix[2][3]) * scale
    return elevation, placement
