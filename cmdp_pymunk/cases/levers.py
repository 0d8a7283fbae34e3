"""Site levers as data, and variants of a case (beyond the paper; docs/levers.md).

The paper keeps the site fixed: how many crews of each type, when material is re-ordered,
how much a crane lift brings, where the storages stand and what they hold. These are the
*levers* a planner moves. A case's ``[levers]`` section (``model.Levers``) names which may
change and within which bounds; a case without it may change any of them.

A *variant* is the case plus lever values, written as *changes*::

    crews.RC+1                      one more RC crew (crews.RC-1: one fewer; crews.RC=3)
    rebars.reorder_at=0.5           a material's reorder point (materials.rebars.reorder_at)
    rebars.crane_lift_quantity=1    its crane lift batch
    ST-rebars.x_m=-6, ST-rebars.y_m=4.5   a storage's centre (storages.ST-rebars.x_m)
    ST-rebars.spot=1                its centre at the lever's second candidate spot
    ST-rebars.capacity=2            its capacity

``make_variant`` applies them and builds the result through ``load.case_from_dict``, so a
variant is validated like any case; ``variant_toml`` prints it as a case file; its name is its
changes (``"RC+1, rebars.reorder_at=0.5"``). An added crew starts at the lever's next
``starts`` point, else at the free start point nearest its type's starts (``free_starts``:
on open floor, off components, storages and the outlet, clear of every other crew's start;
deterministic). A removed crew is its type's last in the file.

Bad lever specs (``lever_checks.lever_problems``, run by ``load.case_from_dict``) and bad
changes are refused before anything runs, each naming the entry and the fix.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from .floorplan import Rect
from .lever_checks import lever_problems  # noqa: F401  (re-exported)
from .load import CaseError, _closest, case_from_dict
from .model import Case, CrewLever

__all__ = ["Change", "Variant", "parse_changes", "parse_variant_option", "make_variant",
           "free_starts", "variant_toml", "lever_problems"]

START_GRID_M = 0.5  # spacing of the candidate start points (free_starts)
START_GAP_M = 0.2  # clearance between two crews' discs, and a disc and an obstacle, at start
_MATERIAL_FIELDS = ("reorder_at", "crane_lift_quantity")
_STORAGE_FIELDS = ("x_m", "y_m", "capacity", "spot")


@dataclass(frozen=True)
class Change:
    """One lever value: ``kind`` "crews" (``field`` "count", ``op`` "+", "-" or "="),
    "materials" or "storages" (``op`` "="); ``name`` the crew type, material or storage."""

    kind: str
    name: str
    field: str
    op: str
    value: float

    @property
    def label(self) -> str:
        """``RC+1``, ``rebars.reorder_at=0.5``, ``ST-rebars.capacity=2``."""
        if self.kind == "crews":
            return f"{self.name}{self.op}{int(self.value)}"
        return f"{self.name}.{self.field}={self.value:g}"


@dataclass(frozen=True)
class Variant:
    """A case plus lever values: ``name`` (the user's, or the changes' label), the
    ``changes``, the validated ``case`` and the ``base`` it was made from."""

    name: str
    changes: tuple[Change, ...]
    case: Case
    base: Case

    @property
    def label(self) -> str:
        return label_of(self.changes)


def label_of(changes: tuple[Change, ...]) -> str:
    """A variant's name by its changes: ``"RC+1, rebars.reorder_at=0.5"``."""
    return ", ".join(c.label for c in changes) or "as the case"


# -- reading changes ------------------------------------------------------------------------

_CREW_STEP = re.compile(r"^(?:crews\.)?(?P<name>.+?)(?P<op>[+-])(?P<n>\d+)$")


def _number(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def parse_changes(case: Case, text: str, source: str = "--variant") -> tuple[Change, ...]:
    """``"crews.RC+1, rebars.reorder_at=0.5"`` -> the changes; ``CaseError`` naming ``source``,
    each bad item and the fix (every one found)."""
    changes, problems = [], []
    for item in (part.strip() for part in text.split(",")):
        if not item:
            continue
        change = _parse_item(case, item, problems)
        if change is not None:
            changes.append(change)
    if not changes and not problems:
        problems.append("names no change; fix: give e.g. crews.RC+1 or "
                        "rebars.reorder_at=0.5 (docs/levers.md)")
    touched = [(c.kind, c.name, c.field) for c in changes]
    for key in dict.fromkeys(k for k in touched if touched.count(k) > 1):
        problems.append(f"{key[1]}.{key[2]} is changed twice; fix: give it once")
    if problems:
        raise CaseError(source, problems)
    return tuple(changes)


def _parse_item(case: Case, item: str, problems: list[str]) -> Change | None:
    crew_types = list(case.crew_types)
    step = _CREW_STEP.match(item) if "=" not in item else None
    if step is not None:
        return _crew_change(case, item, step["name"], step["op"], step["n"], problems)
    key, sep, value = (s.strip() for s in item.partition("="))
    parts = key.split(".")
    if sep and parts[0] == "crews" and len(parts) == 2:
        return _crew_change(case, item, parts[1], "=", value, problems)
    if sep and len(parts) == 1 and key in crew_types:
        return _crew_change(case, item, key, "=", value, problems)
    if parts[0] in ("materials", "storages") and len(parts) == 3:
        kind, name, field = parts
    elif len(parts) == 2:
        name, field = parts
        kind = "materials" if name in case.materials else "storages"
    else:
        problems.append(f'"{item}" is not a change; fix: write crews.TYPE+N, crews.TYPE-N, '
                        "crews.TYPE=N, MATERIAL.reorder_at=X, MATERIAL.crane_lift_quantity=X "
                        "or STORAGE.x_m / y_m / capacity / spot=X (docs/levers.md)")
        return None
    known = list(case.materials) if kind == "materials" else [s.id for s in case.storages]
    fields = _MATERIAL_FIELDS if kind == "materials" else _STORAGE_FIELDS
    if name not in known:
        close = _closest(name, known + [s.id for s in case.storages] + list(case.materials))
        hint = f'did you mean "{close}"?' if close else \
            "name a material (" + ", ".join(case.materials) + ") or a storage (" + \
            ", ".join(s.id for s in case.storages) + ")"
        problems.append(f'"{item}": no material or storage "{name}"; fix: {hint}')
        return None
    if field not in fields:
        close = _closest(field, list(fields))
        problems.append(f'"{item}": {kind} have no lever "{field}"; fix: '
                        + (f'did you mean "{close}"?' if close else
                           "use one of " + ", ".join(fields)))
        return None
    number = _number(value) if sep else None
    if number is None:
        problems.append(f'"{item}": "{value}" is not a number; fix: write {name}.{field}=<number>')
        return None
    return Change(kind, name, field, "=", number)


def _crew_change(case: Case, item: str, name: str, op: str, n: str,
                 problems: list[str]) -> Change | None:
    if name not in case.crew_types:
        close = _closest(name, list(case.crew_types))
        problems.append(f'"{item}": no crew type "{name}"; fix: '
                        + (f'did you mean "{close}"?' if close else
                           "use one of " + ", ".join(case.crew_types)))
        return None
    if not n.isdigit():
        problems.append(f'"{item}": "{n}" is not a count; fix: a whole number of crews, '
                        f"e.g. crews.{name}+1 or crews.{name}=2")
        return None
    return Change("crews", name, "count", op, float(int(n)))


def parse_variant_option(text: str) -> tuple[str, str]:
    """``--variant NAME=CHANGES`` -> (NAME, CHANGES); ValueError naming the fix."""
    name, sep, changes = text.partition("=")
    name = name.strip()
    if not sep or not re.fullmatch(r"[A-Za-z][\w-]*", name) or not changes.strip():
        raise ValueError(f"--variant {text!r} is not NAME=CHANGES; fix: give e.g. --variant "
                         "more_rc=crews.RC+1 (a name of letters, digits, _ or -, then the "
                         "changes, comma-separated; docs/levers.md)")
    return name, changes.strip()


# -- making a variant -----------------------------------------------------------------------

def make_variant(base: Case, changes: str | tuple[Change, ...], name: str | None = None,
                 source: str | None = None) -> Variant:
    """The ``base`` case with ``changes`` (text or parsed), checked against the case's
    ``[levers]`` and validated as a case (``load.case_from_dict``); ``CaseError`` naming
    ``source`` (default ``variant NAME``), every problem and its fix."""
    label = name or (changes if isinstance(changes, str) else label_of(changes))
    source = source or f"variant {label!r}"
    if isinstance(changes, str):
        changes = parse_changes(base, changes, source)
    problems = _bound_problems(base, changes)
    if problems:
        raise CaseError(source, problems)
    data = base.model_dump(mode="json")
    data["case"]["name"] = f"{base.case.name} [{label_of(changes)}]"
    try:
        _apply(base, changes, data)
    except ValueError as err:
        raise CaseError(source, [str(err)]) from None
    case = case_from_dict(data, source)
    return Variant(name or label_of(changes), changes, case, base)


def _count(case: Case, crew_type: str) -> int:
    return sum(c.type == crew_type for c in case.crews)


def _new_count(case: Case, change: Change) -> int:
    now, n = _count(case, change.name), int(change.value)
    return {"+": now + n, "-": now - n, "=": n}[change.op]


def _bound_problems(base: Case, changes: tuple[Change, ...]) -> list[str]:
    """Changes outside the case's ``[levers]`` (or naming a lever it does not give)."""
    problems = []
    levers = base.levers
    for c in changes:
        where = f'"{c.label}"'
        if c.kind == "crews":
            count = _new_count(base, c)
            if count < 0:
                problems.append(f"{where}: the case has {_count(base, c.name)} {c.name} "
                                f"crew(s), so it cannot lose {int(c.value)}; fix: remove at "
                                f"most {_count(base, c.name)}")
                continue
        if levers is None:
            if c.kind == "storages" and c.field == "spot":
                problems.append(f"{where}: the case names no candidate spots; fix: add "
                                f"[levers.storages.{c.name}] spots = [[x, y], ...], or give "
                                "x_m and y_m")
            continue
        lever = getattr(levers, c.kind).get(c.name)
        if lever is None:
            problems.append(f"{where}: [levers] names no {c.kind} lever for {c.name}, so it "
                            f"may not change; fix: add [levers.{c.kind}.{c.name}] with its "
                            "bounds, or leave it out of the variant")
            continue
        if c.kind == "crews":
            if not lever.min <= count <= lever.max:
                problems.append(f"{where}: gives {count} {c.name} crew(s), outside "
                                f"[levers.crews.{c.name}] min = {lever.min}, max = {lever.max}; "
                                "fix: stay within them, or widen the lever")
            continue
        if c.field in ("x_m", "y_m"):
            if lever.region is None:
                problems.append(f"{where}: [levers.storages.{c.name}] gives no region; fix: "
                                f"add region = [x0, y0, x1, y1], or move it by spot=K")
                continue
            lo, hi = (lever.region[0], lever.region[2]) if c.field == "x_m" else \
                (lever.region[1], lever.region[3])
            bounds = (lo, hi)
        elif c.field == "spot":
            if not float(c.value).is_integer() or not 0 <= c.value < len(lever.spots):
                problems.append(f"{where}: [levers.storages.{c.name}] has {len(lever.spots)} "
                                f"spot(s); fix: give spot=0 to {len(lever.spots) - 1}"
                                if lever.spots else
                                f"{where}: [levers.storages.{c.name}] gives no spots; fix: add "
                                "spots = [[x, y], ...]")
            continue
        else:
            bounds = getattr(lever, c.field)
        if bounds is None:
            problems.append(f"{where}: [levers.{c.kind}.{c.name}] gives no bounds for "
                            f"{c.field}; fix: add {c.field} = [lowest, highest]")
        elif not bounds[0] <= c.value <= bounds[1]:
            problems.append(f"{where}: {c.value:g} is outside [levers.{c.kind}.{c.name}] "
                            f"{c.field} = [{bounds[0]:g}, {bounds[1]:g}]; fix: stay within "
                            "them, or widen the lever")
    return problems


def _apply(base: Case, changes: tuple[Change, ...], data: dict) -> None:
    """Write the changes into ``data`` (the base case dumped); ValueError when no start point
    is free for an added crew."""
    for c in changes:
        if c.kind == "materials":
            data["materials"][c.name][c.field] = c.value
        elif c.kind == "storages":
            entry = next(s for s in data["storages"] if s["id"] == c.name)
            if c.field == "spot":
                lever = base.levers.storages[c.name]  # checked by _bound_problems
                entry["x_m"], entry["y_m"] = (float(v) for v in lever.spots[int(c.value)])
            else:
                entry[c.field] = c.value
    # crews last: the free start points are found on the variant's storages
    for c in changes:
        if c.kind != "crews":
            continue
        now, want = _count(base, c.name), _new_count(base, c)
        if want < now:
            keep = [i for i, crew in enumerate(data["crews"]) if crew["type"] == c.name][:want]
            data["crews"] = [crew for i, crew in enumerate(data["crews"])
                             if crew["type"] != c.name or i in keep]
        elif want > now:
            added = _added_crews(base, data, c.name, want - now)
            data["crews"] += added
            lever = (data.get("levers") or {}).get("crews", {}).get(c.name)
            if lever and lever.get("starts"):  # a start taken is no longer free to take
                used = {(a["start_x_m"], a["start_y_m"]) for a in added}
                lever["starts"] = [p for p in lever["starts"] if tuple(p) not in used]


def _added_crews(base: Case, data: dict, crew_type: str, k: int) -> list[dict]:
    ids = {crew["id"] for crew in data["crews"]}
    same = [crew for crew in data["crews"] if crew["type"] == crew_type]
    heading = same[0].get("start_heading_deg", 0.0) if same else 0.0
    lever = base.levers.crews.get(crew_type) if base.levers is not None else None
    points = _lever_starts(base, data, lever, crew_type, k)
    out, n = [], 1
    for x, y in points:
        while f"{crew_type}-{n}" in ids:
            n += 1
        ids.add(f"{crew_type}-{n}")
        out.append({"id": f"{crew_type}-{n}", "type": crew_type, "start_x_m": x,
                    "start_y_m": y, "start_heading_deg": heading})
    return out


def _lever_starts(base: Case, data: dict, lever: CrewLever | None, crew_type: str,
                  k: int) -> list[tuple[float, float]]:
    """The lever's ``starts`` not yet taken by a crew of the variant, then free points."""
    taken = {(c["start_x_m"], c["start_y_m"]) for c in data["crews"]}
    given = [(float(x), float(y)) for x, y in (lever.starts if lever else ())
             if (x, y) not in taken][:k]
    variant = Case.model_validate({**data, "levers": None, "crews": data["crews"] + [
        {"id": f"__start{i}", "type": crew_type, "start_x_m": x, "start_y_m": y}
        for i, (x, y) in enumerate(given)]})
    return given + free_starts(variant, crew_type, k - len(given))


def free_starts(case: Case, crew_type: str, k: int,
                grid_m: float = START_GRID_M) -> list[tuple[float, float]]:
    """``k`` start points for new crews of ``crew_type``: on a grid of ``grid_m`` anchored at
    the type's first start (else the first crew's), inside the plane, each disc clear by
    ``START_GAP_M`` of every component, storage, the outlet and every crew's start disc
    (those placed here included), the nearest to any start of the type first (ties: lower
    y, then lower x). Deterministic; ValueError naming the fix when none is free."""
    if k <= 0:
        return []
    radius = case.crew_types[crew_type].radius_m
    half_w, half_h = case.plane.half_extents
    same = [(c.start_x_m, c.start_y_m) for c in case.crews if c.type == crew_type]
    anchor = same[0] if same else (case.crews[0].start_x_m, case.crews[0].start_y_m)

    def axis(a: float, half: float) -> np.ndarray:
        lo, hi = math.ceil((-half + radius - a) / grid_m), math.floor((half - radius - a) / grid_m)
        return a + grid_m * np.arange(lo, hi + 1)

    xs, ys = np.meshgrid(axis(anchor[0], half_w), axis(anchor[1], half_h))
    x, y = xs.ravel(), ys.ravel()
    free = np.ones(x.shape, dtype=bool)
    grow = radius + START_GAP_M
    for item in (*case.components, *case.storages):
        r = Rect.centred(item.x_m, item.y_m, item.width_m, item.height_m)
        free &= ~((x > r[0] - grow) & (x < r[2] + grow) & (y > r[1] - grow) & (y < r[3] + grow))
    plane = case.plane
    free &= np.hypot(x - plane.outlet_x_m, y - plane.outlet_y_m) >= plane.outlet_radius_m + grow
    discs = [(c.start_x_m, c.start_y_m, case.crew_types[c.type].radius_m) for c in case.crews]
    near = [(sx, sy) for sx, sy in same] or [anchor]
    dist = np.min([np.hypot(x - sx, y - sy) for sx, sy in near], axis=0)
    out: list[tuple[float, float]] = []
    for _ in range(k):
        ok = free.copy()
        for cx, cy, cr in discs:
            ok &= np.hypot(x - cx, y - cy) >= radius + cr + START_GAP_M
        if not ok.any():
            raise ValueError(f"no free start point is left on the plane for another {crew_type} "
                             f"crew ({len(out)} of {k} placed); fix: give start points in "
                             f"[levers.crews.{crew_type}] starts = [[x, y], ...], or add "
                             "fewer crews")
        idx = np.flatnonzero(ok)
        best = idx[np.lexsort((x[idx], y[idx], np.round(dist[idx], 9)))[0]]
        point = (round(float(x[best]), 6), round(float(y[best]), 6))
        out.append(point)
        discs.append((*point, radius))
    return out


# -- printing a variant as a case file ------------------------------------------------------

def _plain(value):
    """A dump made writable as TOML: no None (TOML has no null), lists for tuples."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items() if v is not None}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def variant_toml(variant: Variant | Case, comment: str = "") -> str:
    """A variant (or any case) as a case file: ``load_case`` reads back the same case."""
    import tomli_w

    case = variant.case if isinstance(variant, Variant) else variant
    head = ""
    if isinstance(variant, Variant):
        head = (f"# Variant {variant.name!r} of case {variant.base.case.name!r}: "
                f"{variant.label}\n# (cmdp_pymunk.cases.levers; docs/levers.md)\n")
    if comment:
        head += "".join(f"# {line}\n" for line in comment.splitlines())
    return head + tomli_w.dumps(_plain(case.model_dump(mode="python")))
