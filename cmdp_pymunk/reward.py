"""Rewards: the reaching reward R_r (Eqs. 6-7) and the evaluation reward R_e (Eq. 5)."""

from __future__ import annotations

from .cases.model import EvaluationReward, ReachingReward
from .physics import COMPONENT, CREW, N_KINDS, STORAGE, TASK_AREA, WALL
from .state import LEFT, REACHING, IdleCause, Site


def reach_reward(k: float, target_value: float) -> float:
    """Reward for reaching a target, Eq. (7): R_reach = k * V_Tar."""
    return k * target_value


def eta_by_kind(weights: ReachingReward) -> tuple[float, ...]:
    """eta per object kind: small eta_b for walls, components and storages, a middle eta_a for
    crews and task areas (section 3.6.2)."""
    eta = [0.0] * N_KINDS
    eta[WALL], eta[COMPONENT], eta[STORAGE] = \
        weights.eta_wall, weights.eta_component, weights.eta_storage
    eta[CREW], eta[TASK_AREA] = weights.eta_crew, weights.eta_task_area
    return tuple(eta)


def reaching_reward(contacts, eta, reached_value: float | None, has_target: bool,
                    weights: ReachingReward) -> float:
    """The target-reaching reward, Eq. (6): R_r = eta * R_collision + R_reach + R_time.

    Args:
        contacts: collisions (walls, components, crews) and congestion-area entries (task areas,
            storages) this step, counted per object kind; R_collision is -1 per event.
        eta: the collision punishment index per object kind.
        reached_value: V_Tar of the target reached this step, or None.
        has_target: the time penalty applies only while the crew holds a target.
    """
    collision = -sum(e * n for e, n in zip(eta, contacts, strict=True) if n)
    reach = reach_reward(weights.priority_scale_k, reached_value) if reached_value is not None \
        else 0.0
    time = -weights.time_penalty if has_target else 0.0
    return collision + reach + time


_PREDECESSOR, _AREA = IdleCause.PREDECESSOR, IdleCause.AREA  # module names (``state`` says why)
EVALUATION_TERMS = ("idle_pre", "idle_area", "efficiency", "episode", "path")


def evaluation_reward_terms(site: Site, weights: EvaluationReward) -> dict[str, float]:
    """The terms of R_e, Eq. (5), for one step; their sum is R_e.

    idle_pre: crews idle because their next tasks wait for predecessors; idle_area: crews idle
    because task areas block their tasks; efficiency: the share of crews on the plane that are
    working or heading to a target; episode: the step's share of the episode's duration (plus
    the completion bonus on the step the last task ends); path: crews moving.
    """
    present = idle = idle_pre = idle_area = moving = 0  # one pass: asked at every event
    for c in site.crews:
        if c.status == LEFT:
            continue
        present += 1
        moving += c.moving
        if c.status == REACHING and not c.scope:
            idle += 1
            idle_pre += c.idle_cause == _PREDECESSOR
            idle_area += c.idle_cause == _AREA
    share_working = (present - idle) / present if present else 1.0
    return {
        "idle_pre": weights.idle_predecessor * idle_pre,
        "idle_area": weights.idle_area * idle_area,
        "efficiency": weights.efficiency * share_working,
        "episode": weights.episode + (weights.completion if site.done else 0.0),
        "path": weights.path * moving,
    }
