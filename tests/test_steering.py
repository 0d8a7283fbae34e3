"""The greedy steering stand-in turns toward the crew's best target."""

import math

from agents.steering import STAND_STILL, steer


def test_steer_turns_toward_the_target(tiny_env):
    engine = tiny_env.engine  # crews by index
    i = next(c.index for c in engine.site.crews if c.values)
    crew, world = engine.site.crews[i], engine.world  # the test turns the body
    target = max(crew.values, key=crew.values.get)
    tx, ty = engine.site.target_xy[target]
    x, y, _ = engine.pose(i)
    bearing = math.atan2(ty - y, tx - x)
    world.set_pose(i, x, y, bearing)  # facing it: full speed ahead, no turn
    assert steer(engine, i) == (3, 1, 1)
    world.set_pose(i, x, y, bearing - math.pi / 2)  # target on its left: turn anticlockwise, stand
    assert steer(engine, i) == (0, 1, 2)
    world.set_pose(i, x, y, bearing + math.pi / 2)  # on its right: clockwise
    assert steer(engine, i) == (0, 1, 0)
    crew.values = {}
    assert steer(engine, i) == STAND_STILL
