"""A plan search's space (``training.search.plan_search``; docs/levers.md, "A plan search"): the
levers a plan may move (``Lever``, ``search_space``), the crew screen's first plans
(``crew_screen``), and a plan as changes to the case (``plan_changes``; ``_changes_of`` reads a
plan's label back).

Apart from the search because it is what a plan *is*, before any floor or study: pure functions
of the case (no Optuna but the trial a ``Lever`` asks its value of), read by the search, its
outputs and the tests alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from cmdp_pymunk.cases.levers import Change
from cmdp_pymunk.cases.model import Case

STEPS = 4  # a continuous lever is searched on STEPS + 1 values between its bounds
BASE_LABEL = "as the case"  # the plan that changes nothing: the case as written


@dataclass(frozen=True)
class Lever:
    """One searched lever: the change's ``kind``, ``name`` and ``field`` (as
    ``cmdp_pymunk.cases.levers.Change``), its values from ``low`` to ``high`` (whole numbers
    for crew counts and storage spots, else every ``step``), and its value in the case as
    written (``base``; a storage spot's base is -1: where the case puts it)."""

    kind: str
    name: str
    field: str
    low: float
    high: float
    step: float
    base: float

    @property
    def key(self) -> str:
        """``crews.RC``, ``rebars.reorder_at``, ``ST-rebars.spot``: Optuna's parameter name."""
        return f"crews.{self.name}" if self.kind == "crews" else f"{self.name}.{self.field}"

    @property
    def whole(self) -> bool:
        return self.kind == "crews" or self.field == "spot"

    def suggest(self, trial) -> float:
        if self.whole:
            return float(trial.suggest_int(self.key, int(self.low), int(self.high)))
        return round(trial.suggest_float(self.key, self.low, self.high, step=self.step), 9)

    def change(self, value: float) -> Change | None:
        """The change that sets this lever to ``value``; None for the case's own value."""
        if math.isclose(value, self.base, abs_tol=1e-9):
            return None
        if self.kind == "crews":
            return Change("crews", self.name, "count", "=", float(int(value)))
        return Change(self.kind, self.name, self.field, "=", float(value))


def _grid(low: float, high: float) -> tuple[float, float, float]:
    step = (high - low) / STEPS
    return low, high, step


def search_space(case: Case) -> list[Lever]:
    """The levers a plan may move (module doc): the case's ``[levers]`` with their bounds
    (crew counts ``min``..``max``, a storage's ``spots`` by index, -1 the case's own, its
    ``region`` and every bounded number on ``STEPS + 1`` values), or without ``[levers]``
    every crew type at one fewer (at least 1) to one more crew and every stored material's
    reorder point from 0 to half the lowest capacity of its storages. Levers that cannot move
    (equal bounds) are left out."""
    counts = {t: sum(c.type == t for c in case.crews) for t in case.crew_types}
    out: list[Lever] = []
    levers = case.levers
    if levers is None:
        for t, n in counts.items():
            if n:
                out.append(Lever("crews", t, "count", max(1, n - 1), n + 1, 1, n))
        for m, material in case.materials.items():
            caps = [s.capacity for s in case.storages if s.material == m]
            if caps:
                out.append(Lever("materials", m, "reorder_at", *_grid(0.0, min(caps) / 2),
                                 material.reorder_at))
        return [lv for lv in out if lv.high > lv.low]
    for t, lever in levers.crews.items():
        out.append(Lever("crews", t, "count", lever.min, lever.max, 1, counts.get(t, 0)))
    for m, lever in levers.materials.items():
        for f in ("reorder_at", "crane_lift_quantity"):
            bounds = getattr(lever, f)
            if bounds is not None:
                out.append(Lever("materials", m, f, *_grid(*bounds),
                                 getattr(case.materials[m], f)))
    storages = {s.id: s for s in case.storages}
    for sid, lever in levers.storages.items():
        s = storages[sid]
        if lever.spots:
            out.append(Lever("storages", sid, "spot", -1, len(lever.spots) - 1, 1, -1))
        elif lever.region is not None:
            x0, y0, x1, y1 = lever.region
            out.append(Lever("storages", sid, "x_m", *_grid(x0, x1), s.x_m))
            out.append(Lever("storages", sid, "y_m", *_grid(y0, y1), s.y_m))
        if lever.capacity is not None:
            out.append(Lever("storages", sid, "capacity", *_grid(*lever.capacity), s.capacity))
    return [lv for lv in out if lv.high > lv.low]


def crew_screen(space: list[Lever]) -> list[dict[str, float]]:
    """The plans a ``crew-pairs`` screen tries first, after the case as written (each a value
    per lever key; every other lever as the case): each crew type one fewer and one more
    crew, then every two crew types one more each, within the levers' bounds.

    Why pairs: a crew is paid by the hour, so one more crew pays for itself only if the floor
    gets faster by more than the crew's share of the hourly cost. On the built-in floor one
    more RC crew alone (0.94 x) or FC crew alone (0.97 x) is dearer than the case, and one of
    each is 0.80 x and cheaper (the binding type moves as crews change; docs/levers.md). A
    cost bound makes both single changes infeasible, so a sampler learns to keep away from
    more crews and never tries the pair: it must be met before a model can keep it. With k
    crew types the screen is at most 2k + k(k-1)/2 plans (17 for the built-in floor's 5)."""
    crews = [lv for lv in space if lv.kind == "crews"]
    base = {lv.key: lv.base for lv in space}
    plans = [base | {lv.key: v} for lv in crews for v in (lv.base - 1, lv.base + 1)
             if lv.low <= v <= lv.high]
    plans += [base | {a.key: a.base + 1, b.key: b.base + 1}
              for i, a in enumerate(crews) for b in crews[i + 1:]
              if a.base + 1 <= a.high and b.base + 1 <= b.high]
    return plans


def plan_changes(space: list[Lever], values: dict[str, float]) -> tuple[Change, ...]:
    """The changes of a plan (its value per lever key), in the space's order; a storage spot of
    -1 (the case's own place) is no change."""
    out = []
    for lever in space:
        value = values[lever.key]
        if lever.field == "spot" and value < 0:
            continue
        change = lever.change(value)
        if change is not None:
            out.append(change)
    return tuple(out)


def _changes_of(case: Case, label: str) -> tuple[Change, ...]:
    """The changes of a plan by its label (``levers.label_of``'s text reads back)."""
    if label == BASE_LABEL:
        return ()
    from cmdp_pymunk.cases.levers import parse_changes

    return parse_changes(case, label, "cmdp-plan")
