"""Target evaluation: V_Tar for every target in a crew's scope.

The evaluator is injected into the engine: the stage-2 policy's desired position (Eq. 4), the
priority heuristic (Eq. 9, the default of every env), GA priorities, the lookahead, or a simple
one below. Every evaluator meets the engine at one protocol, ``TargetEvaluator``:

- ``values_for(engine, i) -> {target: V}``: V_Tar for crew i's scope, read from the engine (the
  site, ``engine.pose(j)`` and ``engine.positions`` of every crew, the streams);
- ``prepare(case)``: called once the evaluator is given to an engine for a case: check that it
  fits (a ``ValueError`` naming the fix) and do what is done once (a plan solved);
- ``between_seconds``: False for an evaluator the engine asks inside a second, as the paper's
  process does; True for one that branches the floor (``Engine.clone``) to decide, which the
  engine asks once the second is whole (the lookahead).

The engine asks when a crew's scope changes and after ``reevaluate_after_steps`` steps without
reaching a target (section 3.6). Eqs. 4 and 9 stay pure functions; a rule that sees only the
crew, the site and the crew's position (Eq. 9, nearest, GA priorities) subclasses ``Rule`` and
writes ``target_values(crew, site, position)``; an object with only that method is wrapped in
``RuleAdapter`` by ``make_evaluator``.
"""

from __future__ import annotations

import difflib
import math
from typing import Protocol, runtime_checkable

from .precedence import QUEUE
from .state import CrewState, Site

BETAS = (1.0, 0.5, -1.0)  # Eq. 9's weights of successors, distance and conflicts (section 5.3)


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


def priority_value(successors: float, distance: float, conflicts: float, max_successors: float,
                   max_distance: float, max_conflicts: float,
                   betas: tuple[float, float, float] = BETAS) -> float:
    """Target priority of the heuristic of section 5.3, Eq. (9):
    V' = b1 * Suc / max Suc + b2 * (1 - Dis / max Dis) + b3 * Spa / max Spa,
    the maxima taken over the crew's target scope; a term whose maximum is 0 contributes 0
    (its ratio) -- so a lone target at any distance has the distance term b2.

    More successors raise a target's value, distance (m) lowers it, and space conflicts with
    queued tasks lower it (``betas`` = (b1, b2, b3), the paper's 1, 0.5, -1).
    """
    b1, b2, b3 = betas
    suc = successors / max_successors if max_successors > 0 else 0.0
    dis = distance / max_distance if max_distance > 0 else 0.0
    spa = conflicts / max_conflicts if max_conflicts > 0 else 0.0
    return b1 * suc + b2 * (1.0 - dis) + b3 * spa


@runtime_checkable
class TargetEvaluator(Protocol):
    """V_Tar for a crew's target scope, asked by the engine (see the module doc)."""

    between_seconds: bool

    def prepare(self, case) -> None:
        """Fit ``case`` (a ``ValueError`` naming the fix if it cannot); once per case."""

    def values_for(self, engine, i: int) -> dict[int, float]:
        """V_Tar for every target of crew i's scope (``engine.site.crews[i].scope``)."""


class Evaluator:
    """What every evaluator shares: asked inside a second, fits every case. Subclass it and
    write ``values_for`` (or subclass ``Rule``)."""

    between_seconds = False

    def prepare(self, case) -> None:
        return None

    def values_for(self, engine, i: int) -> dict[int, float]:
        raise NotImplementedError(f"{type(self).__name__}.values_for(engine, i)")


class Rule(Evaluator):
    """An evaluator that sees only the crew, the site and the crew's position:
    ``target_values(crew, site, position)`` (Eq. 9, nearest, GA priorities)."""

    def target_values(self, crew: CrewState, site: Site,
                      position: tuple[float, float]) -> dict[int, float]:
        raise NotImplementedError(f"{type(self).__name__}.target_values(crew, site, position)")

    def values_for(self, engine, i: int) -> dict[int, float]:
        site = engine.site
        return self.target_values(site.crews[i], site, engine.positions[i])


class RuleAdapter(Rule):
    """A foreign object with only ``target_values(crew, site, position)`` as an evaluator."""

    def __init__(self, rule):
        self.rule = rule

    def target_values(self, crew, site, position):
        return self.rule.target_values(crew, site, position)


def target_attributes(crew: CrewState, site: Site, position) -> dict[int, tuple[int, float, int]]:
    """Eq. 9's (Suc, Dis, Spa) per target of the scope: all successors of the crew's task
    there, the straight-line distance (m), and the queued tasks whose areas conflict with
    it."""
    out = {}
    for target, task_index in crew.scope.items():
        dist = math.dist(position, site.target_points[target])
        if task_index >= 0:
            task = site.tasks[task_index]
            spa = sum(site.tasks[o].pool == QUEUE for o in task.conflicts)
            out[target] = (task.all_successors, dist, spa)
        else:
            out[target] = (0, dist, 0)
    return out


class PriorityEvaluator(Rule):
    """The priority heuristic of section 5.3 (Eq. 9): the default evaluator."""

    def __init__(self, betas: tuple[float, float, float] = BETAS):
        self.betas = betas

    def priorities(self, crew, site, position) -> dict[int, float]:
        """Eq. 9's V' for every target of the crew's scope."""
        attrs = target_attributes(crew, site, position)
        if not attrs:
            return {}
        max_s = max(a[0] for a in attrs.values())
        max_d = max(a[1] for a in attrs.values())
        max_c = max(a[2] for a in attrs.values())
        return {t: priority_value(s, d, c, max_s, max_d, max_c, self.betas)
                for t, (s, d, c) in attrs.items()}

    def target_values(self, crew, site, position):
        """Eq. 9's V' as V_Tar (``as_target_values``: a lone target without successors
        scores 0 in Eq. 9, which Eq. 3 would read as no target)."""
        return as_target_values(self.priorities(crew, site, position))


def desired_position_of_first_choice(crew, site, position) -> tuple[float, float]:
    """The heuristic's choice as a stage-2 action: the desired position (Eq. 4, over the
    plane's half extents) at the target Eq. 9 ranks first (lowest index on ties, as
    ``steering.best_target``), so that Eq. 4 ranks it first too."""
    values = PriorityEvaluator().priorities(crew, site, position)
    best = max(values, key=lambda t: (values[t], -t))
    x, y = site.target_xy[best]
    half_w, half_h = site.case.plane.half_extents
    return x / half_w, y / half_h


class UniformEvaluator(Rule):
    """Every target in scope is worth 1."""

    def target_values(self, crew, site, position):
        return {t: 1.0 for t in crew.scope}


class NearestFirstEvaluator(Rule):
    """V = 1 - 0.5 * d / d_max over the scope: the nearest target is worth most.

    The values stay in [0.5, 1] so that no target in scope reads as 0, which Eq. 3 reserves
    for objects outside the scope.
    """

    def target_values(self, crew, site, position):
        dist = {t: math.dist(position, site.target_points[t]) for t in crew.scope}
        d_max = max(dist.values(), default=0.0) or 1.0
        return {t: 1.0 - 0.5 * d / d_max for t, d in dist.items()}


def desired_position_values(desired, crew: CrewState, site: Site) -> dict[int, float]:
    """V_Tar for crew's target scope from a desired position (the stage-2 policy's action),
    Eq. 4 through ``as_target_values``: the one valuation of a desired position, in training
    (``adapters.decision_loop``) and deployment (``agents.models.ModelEvaluator``).

    Args:
        desired: (a1, a2) over the plane's half extents; clipped into [-1, 1] first (the
            action space's bounds; a Gaussian policy's sample can leave them).
        crew: the crew whose scope is valued.
        site: the construction state (target positions, the plane).
    """
    a1 = min(max(float(desired[0]), -1.0), 1.0)
    a2 = min(max(float(desired[1]), -1.0), 1.0)
    half = site.case.plane.half_extents
    return as_target_values({t: desired_position_value((a1, a2), site.target_xy[t], half)
                             for t in crew.scope})


class DesiredPositionEvaluator(Rule):
    """Eq. 4 from a desired position (``desired_position_values``): ``default`` for every
    crew; ``desired_position`` is what a subclass overrides (the trained policy:
    ``agents.models.ModelEvaluator``)."""

    def __init__(self, default: tuple[float, float] = (0.0, 0.0)):
        self.default = default

    def desired_position(self, crew, site, position) -> tuple[float, float]:
        return self.default

    def target_values(self, crew, site, position):
        return desired_position_values(self.desired_position(crew, site, position), crew, site)


# evaluators by name (``make_evaluator``); every way of making an env defaults to the first
EVALUATORS: dict[str, type] = {"priority": PriorityEvaluator, "nearest": NearestFirstEvaluator,
                               "uniform": UniformEvaluator}
DEFAULT_EVALUATOR = "priority"
_CHOICES = ("give " + ", ".join(f'"{name}"' for name in EVALUATORS)
            + ", an evaluate.TargetEvaluator (values_for(engine, i), prepare(case), "
            "between_seconds) or an object with target_values(crew, site, position)")


def make_evaluator(spec: str | TargetEvaluator) -> TargetEvaluator:
    """An evaluator from a name in ``EVALUATORS``, ``spec`` itself if it is a
    ``TargetEvaluator``, or a three-argument rule (``target_values``) in ``RuleAdapter``;
    otherwise a ``ValueError`` (an unknown name, with the closest one) or ``TypeError`` naming
    the accepted choices. (None, values from outside, is the engine's business.)"""
    if isinstance(spec, str):
        if spec in EVALUATORS:
            return EVALUATORS[spec]()
        close = difflib.get_close_matches(spec, EVALUATORS, n=1)
        hint = f'did you mean "{close[0]}"? ' if close else ""
        raise ValueError(f"evaluator {spec!r} is not a known name; {hint}{_CHOICES}")
    if isinstance(spec, TargetEvaluator):
        return spec
    if callable(getattr(spec, "target_values", None)):  # the one place a rule is recognised
        return RuleAdapter(spec)
    raise TypeError(f"evaluator {spec!r} is not an evaluator; {_CHOICES}")


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

