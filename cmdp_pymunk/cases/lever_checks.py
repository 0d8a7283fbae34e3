"""Checks of a case's ``[levers]`` and ``[cost]`` against the case (docs/levers.md).

Run by ``load.case_from_dict`` with the other checks across entries, so a bad lever spec or
cost model is refused, naming the entry and the fix, before anything runs. Kept apart from
``levers`` (which builds variants through ``load``) so that ``load`` imports no module that
imports it.
"""

from __future__ import annotations

import difflib
import math

from .floorplan import GEOMETRY_TOLERANCE_M, Rect
from .model import Case, Levers, Storage

__all__ = ["lever_problems", "cost_problems"]


def _unknown(where: str, kind: str, name: str, names: list[str]) -> str:
    """A lever naming what the case lacks: the nearest name, or the names there are."""
    close = _closest(name, names)
    return (f'{where}: no {kind} "{name}"; fix: '
            + (f'did you mean "{close}"?' if close else "use one of " + ", ".join(names)))


def _closest(name: str, known: list[str]) -> str | None:
    """The known name most like ``name`` (``load._closest``'s rule), or None."""
    for k in known:
        if k.casefold() == name.casefold():
            return k
    close = difflib.get_close_matches(name, known, 1, 0.6)
    return close[0] if close else None


def _count(case: Case, crew_type: str) -> int:
    return sum(c.type == crew_type for c in case.crews)


def cost_problems(case: Case) -> list[str]:
    """What the ``[cost]`` section names that the case does not have."""
    if case.cost is None:
        return []
    known = sorted(case.crew_types)
    return [f'cost: crew_rate_per_h names unknown crew type "{name}"; fix: use one of '
            f"{', '.join(known)}, or remove it (it would cost default_crew_rate_per_h)"
            for name in case.cost.crew_rate_per_h if name not in case.crew_types]


def _disc_on(x: float, y: float, radius: float, rect: Rect) -> bool:
    return (rect[0] - radius < x < rect[2] + radius) and (rect[1] - radius < y < rect[3] + radius)


def lever_problems(case: Case) -> list[str]:
    """What is wrong with the case's ``[levers]`` against the case: unknown names, the case
    itself outside its own bounds, crew starts or storage spots off the plane, on a component
    or storage, or two crews on one start point, a reorder point at or above a capacity the
    storage may have. Run by ``load.case_from_dict``, so a bad spec fails before anything."""
    levers: Levers | None = case.levers
    if levers is None:
        return []
    problems: list[str] = []
    half_w, half_h = case.plane.half_extents
    plane = f"the plane [-{half_w:g}, {half_w:g}] x [-{half_h:g}, {half_h:g}]"
    rects = [(f'component "{c.id}"', Rect.centred(c.x_m, c.y_m, c.width_m, c.height_m))
             for c in case.components]
    for name, lever in levers.crews.items():
        where = f"levers.crews.{name}"
        if name not in case.crew_types:
            problems.append(_unknown(where, "crew type", name, list(case.crew_types)))
            continue
        count = _count(case, name)
        if not lever.min <= count <= lever.max:
            problems.append(f"{where}: the case has {count} {name} crew(s), outside min = "
                            f"{lever.min}, max = {lever.max}; fix: bounds that hold the case")
        radius = case.crew_types[name].radius_m
        storages = [(f'storage "{s.id}"', Rect.centred(s.x_m, s.y_m, s.width_m, s.height_m))
                    for s in case.storages]
        # a crew of an unknown type is the case check's to report (``case_check``), not a
        # KeyError here
        crews = [(f'crew "{c.id}"', c.start_x_m, c.start_y_m,
                  case.crew_types[c.type].radius_m) for c in case.crews
                 if c.type in case.crew_types]
        for i, (x, y) in enumerate(lever.starts):
            at = f"{where}: starts[{i}] ({x:g}, {y:g})"
            if not (abs(x) <= half_w - radius and abs(y) <= half_h - radius):
                problems.append(f"{at} puts the crew's disc outside {plane}; fix: move it "
                                "inside")
            for what, rect in (*rects, *storages):
                if _disc_on(x, y, radius, rect):
                    problems.append(f"{at} lies on {what}; fix: start the crew on open floor")
            for what, cx, cy, cr in crews:
                if math.hypot(x - cx, y - cy) < radius + cr:
                    problems.append(f"{at} overlaps the start of {what}; fix: a start point "
                                    "clear of every crew's start")
            crews.append((f"starts[{i}]", x, y, radius))
    for name, lever in levers.materials.items():
        where = f"levers.materials.{name}"
        if name not in case.materials:
            problems.append(_unknown(where, "material", name, list(case.materials)))
            continue
        if lever.reorder_at is None:
            continue
        for s in case.storages:
            if s.material != name:
                continue
            capacity = _lowest_capacity(levers, s)
            if lever.reorder_at[1] >= capacity:
                problems.append(f"{where}: reorder_at reaches {lever.reorder_at[1]:g}, at or "
                                f'above storage "{s.id}"\'s capacity {capacity:g}, so it would '
                                "re-order on every fetch; fix: keep reorder_at's highest "
                                "below the lowest capacity")
    storages = {s.id: s for s in case.storages}
    for name, lever in levers.storages.items():
        where = f"levers.storages.{name}"
        s = storages.get(name)
        if s is None:
            problems.append(_unknown(where, "storage", name, list(storages)))
            continue
        w, h = s.width_m / 2.0, s.height_m / 2.0
        for i, (x, y) in enumerate(lever.spots):
            at = f"{where}: spots[{i}] ({x:g}, {y:g})"
            if not (abs(x) + w <= half_w and abs(y) + h <= half_h):
                problems.append(f"{at} puts the storage outside {plane}; fix: a spot with the "
                                "whole storage on the plane")
            r = Rect.centred(x, y, s.width_m, s.height_m)
            for what, rect in rects:
                if r.overlaps(rect, GEOMETRY_TOLERANCE_M):
                    problems.append(f"{at} puts the storage on {what} (crews could not stand "
                                    "in it to fetch); fix: a spot on open floor")
        if lever.region is not None:
            x0, y0, x1, y1 = lever.region
            if x0 - w < -half_w or x1 + w > half_w or y0 - h < -half_h or y1 + h > half_h:
                problems.append(f"{where}: region [{x0:g}, {y0:g}, {x1:g}, {y1:g}] lets the "
                                f"storage ({s.width_m:g} x {s.height_m:g} m) leave {plane}; "
                                "fix: shrink the region by half the storage on each side")
    return problems


def _lowest_capacity(levers: Levers, storage: Storage) -> float:
    lever = levers.storages.get(storage.id)
    if lever is not None and lever.capacity is not None:
        return min(storage.capacity, lever.capacity[0])
    return storage.capacity
