"""Greedy steering: head straight for the crew's highest-value target.

A stand-in low level for tests and the first demo: it turns toward the target and walks when
roughly facing it, with no path planning (the navigator of the simulation issue replaces it).
It reads the engine's state, not the rays, and is a pure function of that state, so two runs of
the same seed take the same actions.
"""

from __future__ import annotations

import math

from cmdp_pymunk.move import STAND_STILL
from cmdp_pymunk.policy import best_target


def steer(engine, i: int):
    """The MultiDiscrete([4, 3, 3]) action for crew i of ``engine``."""
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


class Steering:
    """Greedy steering as a low level (``cmdp_pymunk.policy.LowLevel``): no plans, no state."""

    reads_rays = False

    def bind(self, engine) -> None:
        """Fits every case."""

    def reset(self, seed: int) -> None:
        """Draws no random numbers."""

    def actions(self, engine, observations=None) -> list:
        return [steer(engine, i) for i in range(len(engine.site.crews))]


def steer_all(env) -> dict:
    """Greedy actions for every agent of a ``CMDPEnv``, by agent name."""
    return env.agent_actions(Steering(), None)
