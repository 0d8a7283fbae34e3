"""The logistics role: when a crew that fetches asks for a storage's next crane lift.

In the paper a storage's next lift is asked for only once it is empty (Table 1's c7: the crew
that finds it so waits for the lift). A case's reorder point (``Material.reorder_at``) asks
earlier, by a fixed rule. This module makes the question a role of its own, injected into the
engine like the evaluator (``Engine(case, ..., logistics=...)``), so a rule or a learned
policy decides from the floor's state. Every implementation meets the engine at one protocol,
``Logistics``:

- ``levels(material) -> (stock, ...)``: the decision levels (in the material's unit). A crew
  fetching at a storage is asked once at each level its storage's stock falls to, with stock
  left and no lift asked for, and asked at every level again once a lift lands
  (``construct.decision_level``). The event floor stops its span at the second a level is
  reached (``construct.next_change_in``), so both floors ask at the same second;
- ``lift_now(engine, i, storage) -> bool``: whether crew i, fetching at storage index
  ``storage``, asks for the next lift now (``construct.order_lift``, the request a reorder
  point makes); "no" lets the stock run on to the next level, or empty (c7);
- ``prepare(case)``: called once the role is given to an engine: check that it fits the case
  (a ``ValueError`` naming the fix) and resolve what depends on it.

``logistics=None`` (every engine's default) keeps the case's reorder point as the rule, which
is the paper's c7 alone where the case sets none. An injected role replaces the case's reorder
point. Like an evaluator, a role is shared by an engine's clones: it keeps no per-episode
state of its own (what was asked is the site's, ``StorageState.asked_at``).

Three roles ship: ``Never`` (the paper's c7: never asks early), ``ReorderPoint`` (a fixed
reorder point as a role: the same schedule as the case's ``reorder_at``) and ``CraneIdle`` (a
state rule: lift now when the crane has nothing to do). ``FromOutside`` leaves the answer to a
caller (the stage-2 decision loop's logistics decisions, ``adapters.decision_loop``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Protocol, runtime_checkable

if TYPE_CHECKING:
    from .cases.model import Case
    from .engine import Engine


@runtime_checkable
class Logistics(Protocol):
    """When a fetching crew asks for the next lift (see the module doc)."""

    def prepare(self, case: Case) -> None:
        """Fit ``case`` (a ``ValueError`` naming the fix if it cannot); once per engine."""

    def levels(self, material: str) -> tuple[float, ...]:
        """The stock levels of ``material`` (its unit) at which a fetching crew is asked."""

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        """Whether crew i, fetching at storage ``storage``, asks for the next lift now."""


def _check_materials(case: Case, named, who: str) -> None:
    unknown = sorted(set(named) - set(case.materials))
    if unknown:
        raise ValueError(f"{who}: no material {', '.join(map(repr, unknown))} in case "
                         f"{case.case!r}; fix: name one of {', '.join(sorted(case.materials))}")


class Never:
    """Never asks early: a storage's lift is asked for once it is empty (c7), the paper's
    logistics. Asked nowhere (no levels), so it runs exactly as a case without reorder
    points."""

    def prepare(self, case: Case) -> None:
        return None

    def levels(self, material: str) -> tuple[float, ...]:
        return ()

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        return False


class ReorderPoint:
    """A fixed reorder point as a role: asked once a storage's stock is down to ``at`` (every
    material's, in its unit; or ``{material: stock}``, the others never early), it always asks
    for the next lift. The same schedule as the case with ``Material.reorder_at`` = ``at``
    (``tests/test_logistics.py``). ``lifts``: ``at`` in crane lifts of each material instead
    (0.5: half a lift, the reorder floor's point)."""

    def __init__(self, at: float | Mapping[str, float] | None = None, *,
                 lifts: float | None = None):
        if (at is None) == (lifts is None):
            raise ValueError("ReorderPoint: give the point either as at= (stock, in each "
                             "material's unit) or as lifts= (a share of its crane lift), "
                             "e.g. ReorderPoint(lifts=0.5)")
        given = lifts if at is None else at
        values = given.values() if isinstance(given, Mapping) else (given,)
        if any(not (math.isfinite(v) and v >= 0.0) for v in values):
            raise ValueError(f"ReorderPoint: {given!r} holds a point below 0 or not finite; "
                             "fix: a stock of 0 or more (0: never early)")
        self.at, self.lifts = at, lifts
        self._points: dict[str, float] = {}

    def prepare(self, case: Case) -> None:
        if isinstance(self.at, Mapping):
            _check_materials(case, self.at, "ReorderPoint")
            self._points = {m: float(self.at.get(m, 0.0)) for m in case.materials}
        elif self.at is not None:
            self._points = dict.fromkeys(case.materials, float(self.at))
        else:
            self._points = {m: self.lifts * x.crane_lift_quantity
                            for m, x in case.materials.items()}

    def levels(self, material: str) -> tuple[float, ...]:
        at = self._points.get(material, 0.0)
        return (at,) if at > 0.0 else ()  # 0: no reorder point, as Material.reorder_at

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        return True


class Levels:
    """Decision levels as shares of each material's crane lift (``shares``; (0.75, 0.5,
    0.25): a quarter of a lift apart), resolved for the case in ``prepare``; what a role
    that decides from the floor's state is asked at. Subclass it and write ``lift_now``."""

    def __init__(self, shares: tuple[float, ...] = (0.75, 0.5, 0.25)):
        if not shares or any(not (math.isfinite(s) and s > 0.0) for s in shares):
            raise ValueError(f"{type(self).__name__}: decision levels {shares!r}; fix: one or "
                             "more shares of a crane lift above 0, e.g. (0.75, 0.5, 0.25)")
        self.shares = tuple(sorted(shares, reverse=True))
        self._levels: dict[str, tuple[float, ...]] = {}

    def prepare(self, case: Case) -> None:
        self._levels = {m: tuple(s * x.crane_lift_quantity for s in self.shares)
                        for m, x in case.materials.items()}

    def levels(self, material: str) -> tuple[float, ...]:
        return self._levels.get(material, ())

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        raise NotImplementedError(f"{type(self).__name__}.lift_now(engine, i, storage)")


class CraneIdle(Levels):
    """A state rule: at each decision level, ask for the next lift when the crane has nothing
    under way and nothing queued (a lift now delays no other request); otherwise let the stock
    run on to the next level, or empty (c7)."""

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        crane = engine.site.crane
        return crane.current is None and not crane.queue


class FromOutside(Levels):
    """The answer comes from outside the engine (the stage-2 decision loop's policy): asked,
    it records the question in ``engine.lift_questions`` and says "not yet"; the engine's
    ``advance`` stops after the span, and the caller answers each question with
    ``engine.answer_lift(i, lift)`` before the next one runs (a "yes" asks for the lift at the
    same second; "no" for every question is ``Never``'s schedule)."""

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        engine.lift_questions.append((i, storage))
        return False


def make_logistics(spec: Logistics | None) -> Logistics | None:
    """``spec`` itself if it is a ``Logistics`` (or None: the case's reorder point decides);
    otherwise a ``TypeError`` naming the members a role needs."""
    if spec is None or isinstance(spec, Logistics):
        return spec
    raise TypeError(f"logistics {spec!r} is not a logistics role; fix: give a "
                    "logistics.Logistics (prepare(case), levels(material), lift_now(engine, i, "
                    "storage)), e.g. logistics.Never() or logistics.ReorderPoint(lifts=0.5), "
                    "or None for the case's reorder point")


__all__ = ["Logistics", "Never", "ReorderPoint", "Levels", "CraneIdle", "FromOutside",
           "make_logistics"]
