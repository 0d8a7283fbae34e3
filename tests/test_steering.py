"""The greedy steering stand-in turns toward the crew's best target."""

import math

from agents.steering import STAND_STILL, steer


def test_steer_turns_toward_the_target(tiny_env):
    env = tiny_env
    i = next(c.index for c in env.site.crews if c.values)
    crew, body = env.site.crews[i], env.world.bodies[i]
    target = max(crew.values, key=crew.values.get)
    tx, ty = env.site.target_xy[target]
    x, y = body.position
    bearing = math.atan2(ty - y, tx - x)
    agent = env.possible_agents[i]
    body.angle = bearing  # facing it: full speed ahead, no turn
    assert steer(env, agent) == (3, 1, 1)
    body.angle = bearing - math.pi / 2  # target on its left: turn anticlockwise, stand
    assert steer(env, agent) == (0, 1, 2)
    body.angle = bearing + math.pi / 2  # on its right: clockwise
    assert steer(env, agent) == (0, 1, 0)
    crew.values = {}
    assert steer(env, agent) == STAND_STILL
