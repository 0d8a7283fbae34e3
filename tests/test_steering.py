"""The greedy steering stand-in turns toward the crew's best target."""

import math

from agents.steering import STAND_STILL, steer


def test_steer_turns_toward_the_target(tiny_env):
    engine = tiny_env.engine  # crews by index
    i = next(c.index for c in engine.site.crews if c.values)
    crew, body = engine.site.crews[i], engine.world.bodies[i]  # the test turns the body
    target = max(crew.values, key=crew.values.get)
    tx, ty = engine.site.target_xy[target]
    x, y, _ = engine.pose(i)
    bearing = math.atan2(ty - y, tx - x)
    body.angle = bearing  # facing it: full speed ahead, no turn
    assert steer(engine, i) == (3, 1, 1)
    body.angle = bearing - math.pi / 2  # target on its left: turn anticlockwise, stand
    assert steer(engine, i) == (0, 1, 2)
    body.angle = bearing + math.pi / 2  # on its right: clockwise
    assert steer(engine, i) == (0, 1, 0)
    crew.values = {}
    assert steer(engine, i) == STAND_STILL
