"""state() / state_space: the documented global state, by hand on the tiny case, and through a
whole episode."""

import math

import numpy as np
import pytest

import cmdp_pymunk
from cmdp_pymunk.adapters.global_state import CREW_FEATURES, state_layout, state_size


def test_layout_blocks_follow_each_other(tiny_case):
    layout = state_layout(tiny_case)
    assert [name for name, _, _ in layout] == ["time", "crews", "tasks", "storages", "crane",
                                               "crane_queue"]
    # 1 + 17 x 4 crews + 5 x 4 tasks + 2 x 1 storage + 3 + 2 x 4 crews = 102
    assert [length for _, _, length in layout] == [1, 68, 20, 2, 3, 8]
    assert all(a[1] + a[2] == b[1] for a, b in zip(layout, layout[1:], strict=False))
    assert state_size(tiny_case) == 102
    assert state_size(cmdp_pymunk.load_case(None)) == 578  # 1 + 119 + 435 + 6 + 3 + 14


def test_state_after_reset_by_hand(tiny_case):
    env = cmdp_pymunk.parallel_env(case=tiny_case, seed=0)
    with pytest.raises(RuntimeError, match="reset"):
        env.state()
    env.reset(seed=0)
    s = env.state()
    assert s.dtype == np.float32 and s.shape == env.state_space.shape == (102,)
    assert env.state_space.contains(s)
    assert s[0] == 0.0  # time 0 of 5000 s
    # X-1 starts at (-6, 3) on the 20 x 12 m plane, heading 0, reaching, holding the scope
    # {A, B}; the nearest-first evaluator values A (-3, 0) above B (5, 0)
    x1 = s[1:1 + CREW_FEATURES]
    np.testing.assert_allclose(x1[:4], [-0.6, 0.5, 1.0, 0.0], atol=1e-6)
    np.testing.assert_array_equal(x1[4:10], [1, 0, 0, 0, 0, 0])
    assert x1[10] == 0.0 and x1[11] == 1.0
    np.testing.assert_allclose(x1[12:14], [-0.3, 0.0], atol=1e-6)
    assert x1[14] == 0.0 and x1[15] == 0.0
    tasks = s[69:89].reshape(4, 5)  # X-A queue, K-A wait, X-B queue, M-C wait; no progress
    np.testing.assert_array_equal(tasks[:, :4], [[0, 1, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0],
                                                 [1, 0, 0, 0]])
    np.testing.assert_array_equal(tasks[:, 4], 0.0)
    np.testing.assert_array_equal(s[89:91], [0.0, 0.0])  # storage empty, no lift pending
    np.testing.assert_array_equal(s[91:], 0.0)  # the crane idle, nobody queued


def test_state_follows_a_whole_episode(tiny_case):
    from agents.navigator import Navigator

    env = cmdp_pymunk.parallel_env(case=tiny_case, seed=1)
    env.reset(seed=1)
    navigator = Navigator()
    layout = {name: start for name, start, _ in state_layout(tiny_case)}
    crane, queue = layout["crane"], layout["crane_queue"]
    seen_crane = seen_load = seen_stock = 0
    while env.agents:
        env.step(env.agent_actions(navigator, None))
        s = env.state()
        assert env.state_space.contains(s)
        site = env.engine.site
        assert s[0] == pytest.approx(site.time_s / env.max_time_s)
        for crew in site.crews:
            row = s[1 + CREW_FEATURES * crew.index:1 + CREW_FEATURES * (crew.index + 1)]
            assert row[4 + int(crew.status)] == 1.0 and row[4:10].sum() == 1.0
            x, y = env.engine.positions[crew.index]
            assert row[0] == pytest.approx(x / 10.0, abs=1e-6)
            assert row[3] == pytest.approx(math.sin(env.engine.world.bodies[crew.index].angle),
                                           abs=1e-6)
            seen_load += row[10] > 0
        if site.crane.current is not None:
            seen_crane += 1
            assert s[crane] == 1.0 and s[queue + 2 * site.crane.current.crew] == 1.0
        assert s[crane + 2] == pytest.approx(len(site.crane.queue) / 4)
        seen_stock += s[layout["storages"]] > 0
    assert env.engine.site.done
    s = env.state()
    tasks = s[layout["tasks"]:layout["storages"]].reshape(4, 5)
    np.testing.assert_array_equal(tasks[:, 3], 1.0)  # every task ended, progress 1
    np.testing.assert_allclose(tasks[:, 4], 1.0)
    assert seen_crane and seen_load and seen_stock  # the crane, loads and stock all showed
