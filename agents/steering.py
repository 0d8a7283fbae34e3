"""Greedy steering: head straight for the crew's highest-value target.

A stand-in low level for tests and the first demo: it turns toward the target and walks when
roughly facing it, with no path planning (the navigator of the simulation issue replaces it).
It reads the engine's state, not the rays, and is a pure function of that state, so two runs of
the same seed take the same actions.
"""

from __future__ import annotations

import math

from cmdp_pymunk.engine import engine_of
from cmdp_pymunk.move import STAND_STILL


def best_target(crew) -> int:
    """The target of highest V_Tar in the crew's scope (lowest index on ties), or -1."""
    if not crew.values:
        return -1
    return max(crew.values, key=lambda t: (crew.values[t], -t))


def steer(floor, i: int):
    """The MultiDiscrete([4, 3, 3]) action for crew i of ``floor`` (an engine, or an env over
    one)."""
    engine = engine_of(floor)
    crew = engine.site.crews[i]
    target = best_target(crew)
    if not crew.moving or target < 0:
        return STAND_STILL
    x, y, heading = engine.pose(i)
    tx, ty = engine.site.target_xy[target]
    error = math.atan2(ty - y, tx - x) - heading
    error = math.atan2(math.sin(error), math.cos(error))
    turn = 1 if abs(error) < math.radians(5) else (2 if error > 0 else 0)
    forward = 3 if abs(error) < math.radians(30) else (1 if abs(error) < math.radians(60) else 0)
    return (forward, 1, turn)


def steer_all(env) -> dict:
    """Actions for every live agent of a ``CMDPEnv`` (its names mapped to crew indices)."""
    return {agent: steer(env.engine, env.agent_index[agent]) for agent in env.agents}
