"""P_phy: decoding reaching actions into crew velocities, slowed by congestion (Eq. 1).

The reaching action is ``MultiDiscrete([4, 3, 3])`` (section 3.6.2): forward
{0, 0.3, 0.8, 1} x v_f (no backward movement), lateral {-1, 0, 1} x v_l, turn {-1, 0, 1} x v_tu.
Each nominal velocity is first reduced by Eq. 1 to the crew's current maximum.
"""

from __future__ import annotations

import math

from .physics import Physics
from .state import CrewState, Site, inside

FORWARD_FRACTIONS = (0.0, 0.3, 0.8, 1.0)
SIDE_SIGNS = (-1.0, 0.0, 1.0)  # lateral: right, none, left; turn: clockwise, none, anticlockwise
ACTION_NVEC = (len(FORWARD_FRACTIONS), len(SIDE_SIGNS), len(SIDE_SIGNS))
STAND_STILL = (0, 1, 1)


def congested_velocity(nominal: float, deceleration: float, congestion: float,
                       floor: float) -> float:
    """Maximum velocity inside congestion areas, Eq. (1): v = max(c * I_area * v_i, v_min).

    Args:
        nominal: v_i, the crew's nominal forward, lateral or turning velocity.
        deceleration: c in [0, 1], below 1 while the crew carries materials.
        congestion: I_area in [0, 1] of the areas the crew stands in (1: none).
        floor: v_min, so that a crew can always leave a congested area.
    """
    return max(deceleration * congestion * nominal, floor)


def congestion_index(site: Site, x: float, y: float) -> float:
    """I_area at a point: the most congested (lowest) index of the areas that contain it.

    Task areas take Table 2's index of their task type; a storage's index falls with its
    stock (``Site.storage_congestion``). Outside every area it is 1.
    """
    index = 1.0
    for t in site.active_areas:
        task = site.tasks[t]
        if task.congestion_index < index and inside(x, y, task.area):
            index = task.congestion_index
    for st in site.storages:
        if st.stock > 0.0 and inside(x, y, st.rect):
            index = min(index, site.storage_congestion(st))
    return index


def velocity_limits(crew: CrewState, congestion: float, lateral_m_s: float,
                    turning_rad_s: float) -> tuple[float, float, float]:
    """The crew's current maximum forward, lateral and turning velocities (Eq. 1 on each).

    v_min is the lowest of the nominal linear velocities (section 3.4), so a crew can always
    creep out of congestion; turning keeps the same share of its nominal rate.
    """
    c = crew.spec.carry_deceleration if crew.load > 0.0 else 1.0
    v_f = crew.spec.velocity_m_s
    v_min = min(v_f, lateral_m_s)
    turn_floor = turning_rad_s * v_min / v_f
    return (congested_velocity(v_f, c, congestion, v_min),
            congested_velocity(lateral_m_s, c, congestion, v_min),
            congested_velocity(turning_rad_s, c, congestion, turn_floor))


def reaching_action(action, crew: CrewState) -> tuple[int, int, int]:
    """The three indices of a ``MultiDiscrete(ACTION_NVEC)`` action (forward, lateral, turn);
    a ValueError names the crew and what was expected for anything else (a negative index
    would otherwise pick from the end of the table without a word)."""
    try:
        f, s, t = action
        f, s, t = int(f), int(s), int(t)
    except (TypeError, ValueError):
        f = -1
    nf, ns, nt = ACTION_NVEC
    if not (0 <= f < nf and 0 <= s < ns and 0 <= t < nt):
        raise ValueError(f"{crew.id} (crew {crew.index}): reaching action {action!r} is not "
                         f"three whole numbers in MultiDiscrete({list(ACTION_NVEC)}) "
                         f"(forward 0-{nf - 1}, lateral 0-{ns - 1}, turn 0-{nt - 1}); fix: give "
                         f"one such triple per crew, e.g. {STAND_STILL} to stand still")
    return f, s, t


def apply_reaching_actions(world: Physics, site: Site, actions) -> None:
    """Set each moving crew's desired velocity from its action; every other crew stands."""
    sim = site.case.simulation
    lateral, turning = sim.lateral_velocity_m_s, math.radians(sim.turning_rate_deg_s)
    for crew in site.crews:
        action = actions[crew.index] if crew.moving else None
        if action is None:
            world.drive(crew.index, 0.0, 0.0, 0.0)
            continue
        f, s, t = reaching_action(action, crew)
        x, y, angle = world.pose(crew.index)
        v_f, v_l, v_tu = velocity_limits(crew, congestion_index(site, x, y), lateral, turning)
        forward = FORWARD_FRACTIONS[f] * v_f
        side = SIDE_SIGNS[s] * v_l
        cos_a, sin_a = math.cos(angle), math.sin(angle)
        world.drive(crew.index, forward * cos_a - side * sin_a, forward * sin_a + side * cos_a,
                    SIDE_SIGNS[t] * v_tu)
