"""Target evaluation: V_Tar for every target in a crew's scope.

The evaluator is injected into the env: the stage-2 policy's desired position (Eq. 4), the
priority heuristic (Eq. 9, in ``agents``), GA priorities, or a simple one below. An evaluator
is any object with ``target_values(crew, site, position) -> dict[target, V]``.
The env calls it when a crew's scope changes and after ``reevaluate_after_steps`` steps
without reaching a target (section 3.6).
"""

from __future__ import annotations

import math
from typing import Protocol

from .state import CrewState, Site


def desired_position_value(desired: tuple[float, float], target_xy: tuple[float, float],
                           half_extents: tuple[float, float]) -> float:
    """Target priority from the desired position, Eq. (4):
    V = 1 - sqrt((a1 - x/x_max)^2 + (a2 - y/y_max)^2).

    The plane's origin is its centre and (x_max, y_max) are its half extents, so x/x_max and
    the desired position (a1, a2) share [-1, 1]. V is 1 at the desired position and falls
    linearly with distance in that normalized plane (down to 1 - 2*sqrt(2)).
    """
    return 1.0 - math.hypot(desired[0] - target_xy[0] / half_extents[0],
                            desired[1] - target_xy[1] / half_extents[1])


def as_target_values(scores: dict[int, float]) -> dict[int, float]:
    """Ranking scores (Eq. 4's or Eq. 9's) as V_Tar: mapped linearly onto [0.5, 1] over the
    scope, best 1 (all 1 when they tie).

    Both equations can score a target 0 or below. As V_Tar that would hide the target (Eq. 3
    reserves 0 for objects outside the scope) and make reaching it worth nothing or less
    (Eq. 7). The mapping keeps the ranking, so the target an evaluator prefers is unchanged.
    """
    if not scores:
        return {}
    low, high = min(scores.values()), max(scores.values())
    span = high - low
    return {t: 1.0 if span <= 0 else 0.5 + 0.5 * (v - low) / span for t, v in scores.items()}


class TargetEvaluator(Protocol):
    def target_values(self, crew: CrewState, site: Site,
                      position: tuple[float, float]) -> dict[int, float]: ...


class BranchingEvaluator(Protocol):
    """An evaluator that may branch the floor (``Engine.clone``) to value a scope, such as
    the lookahead (``agents.lookahead``). The engine asks it only between whole seconds, when
    the state is complete: ``between_seconds`` is True, and the engine calls
    ``values_for(engine, i)`` for each crew whose scope needs values, in crew order, at the
    end of ``reset`` and of every ``advance``."""

    between_seconds: bool

    def values_for(self, engine, i: int) -> dict[int, float]: ...


def asks_between_seconds(evaluator) -> bool:
    """Whether ``evaluator`` is a ``BranchingEvaluator`` (valued between seconds)."""
    return bool(getattr(evaluator, "between_seconds", False))


class UniformEvaluator:
    """Every target in scope is worth 1."""

    def target_values(self, crew, site, position):
        return {t: 1.0 for t in crew.scope}


class NearestFirstEvaluator:
    """V = 1 - 0.5 * d / d_max over the scope: the nearest target is worth most.

    The values stay in [0.5, 1] so that no target in scope reads as 0, which Eq. 3 reserves
    for objects outside the scope.
    """

    def target_values(self, crew, site, position):
        dist = {t: math.dist(position, site.target_xy[t]) for t in crew.scope}
        d_max = max(dist.values(), default=0.0) or 1.0
        return {t: 1.0 - 0.5 * d / d_max for t, d in dist.items()}


class DesiredPositionEvaluator:
    """Eq. 4 from a desired position per crew (the stage-2 policy's action), as V_Tar
    through ``as_target_values``. ``desired_position`` is what a subclass overrides."""

    def __init__(self, default: tuple[float, float] = (0.0, 0.0)):
        self.desired: dict[int, tuple[float, float]] = {}
        self.default = default

    def desired_position(self, crew, site, position) -> tuple[float, float]:
        return self.desired.get(crew.index, self.default)

    def target_values(self, crew, site, position):
        desired = self.desired_position(crew, site, position)
        half = site.case.plane.half_extents
        return as_target_values({t: desired_position_value(desired, site.target_xy[t], half)
                                 for t in crew.scope})


def needs_values(crew: CrewState, reevaluate_after_steps: int) -> bool:
    """Whether the crew's target scope must be valued now (section 3.6): it has just acquired
    a scope (its values do not cover it), or it has gone ``reevaluate_after_steps`` steps
    without reaching a target."""
    if not crew.scope:
        return False
    stale = crew.steps_since_reach > 0 and crew.steps_since_reach % reevaluate_after_steps == 0
    return stale or crew.values.keys() != crew.scope.keys()


def crews_needing_values(site: Site) -> list[CrewState]:
    """The crews whose scope must be valued now, in crew order."""
    every = site.case.simulation.reevaluate_after_steps
    return [crew for crew in site.crews if needs_values(crew, every)]


def assign_target_values(site: Site, evaluator: TargetEvaluator, positions) -> None:
    """Value the scope of every crew that needs it: a new scope, or too long without reaching."""
    for crew in crews_needing_values(site):
        crew.values = dict(evaluator.target_values(crew, site, positions[crew.index]))
