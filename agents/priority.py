"""The priority heuristic of section 5.3 (Eq. 9) as a target evaluator.

It fills V_Tar in place of the high-level policy: more successors raise a target's value,
distance lowers it, and space conflicts with queued tasks lower it (beta = 1, 0.5, -1).
"""

from __future__ import annotations

import math

from cmdp_pymunk.evaluate import as_target_values
from cmdp_pymunk.state import CrewState, Pool, Site

BETAS = (1.0, 0.5, -1.0)  # section 5.3


def priority_value(successors: float, distance: float, conflicts: float, max_successors: float,
                   max_distance: float, max_conflicts: float,
                   betas: tuple[float, float, float] = BETAS) -> float:
    """Target priority, Eq. (9):
    V' = b1 * Suc / max Suc + b2 * (1 - Dis / max Dis) + b3 * Spa / max Spa,
    the maxima taken over the crew's target scope; a term whose maximum is 0 contributes 0
    (its ratio) -- so a lone target at any distance has the distance term b2.
    """
    b1, b2, b3 = betas
    suc = successors / max_successors if max_successors > 0 else 0.0
    dis = distance / max_distance if max_distance > 0 else 0.0
    spa = conflicts / max_conflicts if max_conflicts > 0 else 0.0
    return b1 * suc + b2 * (1.0 - dis) + b3 * spa


def target_attributes(crew: CrewState, site: Site, position) -> dict[int, tuple[int, float, int]]:
    """(Suc, Dis, Spa) per target of the scope: all successors of the crew's task there, the
    straight-line distance, and the queued tasks whose areas conflict with it."""
    out = {}
    for target, task_index in crew.scope.items():
        dist = math.dist(position, site.target_xy[target])
        if task_index >= 0:
            task = site.tasks[task_index]
            spa = sum(site.tasks[o].pool == Pool.QUEUE for o in task.conflicts)
            out[target] = (task.all_successors, dist, spa)
        else:
            out[target] = (0, dist, 0)
    return out


class PriorityEvaluator:
    """Eq. 9 as an evaluator for ``cmdp_pymunk.parallel_env(evaluator=...)``."""

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
