"""The reaching observation space is bounded by what each feature can be, and soaked
observations (random actions, before the env's clip) stay inside it."""

import math

import numpy as np
import pytest
from conftest import tiny_dict

import cmdp_pymunk
from cmdp_pymunk import observe
from cmdp_pymunk.cases.load import case_from_dict
from cmdp_pymunk.move import ACTION_NVEC


def test_bounds_by_hand_for_the_tiny_case():
    data = tiny_dict()
    data["simulation"]["target_memory"] = True
    data["simulation"]["sight_distance_m"] = 12.0
    env = cmdp_pymunk.parallel_env(case=case_from_dict(data), seed=0)
    space = env.observation_space(env.possible_agents[0])
    n = env.rays.n_rays * 4
    assert space.shape == (n + 3 + 4,) and space.dtype == np.float32
    np.testing.assert_array_equal(space.low[0:n:4], 0.0)  # relative length
    np.testing.assert_array_equal(space.high[0:n:4], 1.0)
    np.testing.assert_array_equal(space.low[1:n:4], -1.0)  # emission angle over pi
    np.testing.assert_array_equal(space.high[2:n:4], 1.0)  # type id over 6, priority
    np.testing.assert_array_equal(space.high[3:n:4], 1.0)
    # velocities: fastest type XC hypot(1.0, 0.1) = 1.00499 m/s over the slowest v_f 0.5
    cap = math.hypot(1.0, 0.1) / 0.5  # 2.00998
    np.testing.assert_allclose(space.high[n:n + 3], cap, rtol=1e-6)
    np.testing.assert_allclose(space.low[n:n + 3], [-cap, -cap, 0.0], rtol=1e-6)
    # memory: flag [0, 1], offsets +-hypot(20, 12) / 12 = 1.9437, age [0, 1]
    reach = math.hypot(20.0, 12.0) / 12.0
    np.testing.assert_allclose(space.low[n + 3:], [0.0, -reach, -reach, 0.0], rtol=1e-6)
    np.testing.assert_allclose(space.high[n + 3:], [1.0, reach, reach, 1.0], rtol=1e-6)
    assert np.isfinite(space.low).all() and np.isfinite(space.high).all()


def test_builtin_case_velocity_cap():
    env = cmdp_pymunk.parallel_env(seed=0)
    space = env.observation_space(env.possible_agents[0])
    at = env.rays.velocity_at
    # fastest type RC hypot(0.7, 0.1) = 0.7071 m/s over the slowest v_f (HIC) 0.3 m/s
    assert space.high[at] == pytest.approx(math.hypot(0.7, 0.1) / 0.3, rel=1e-6)
    assert space.high[at + 4] == pytest.approx(math.hypot(54.0, 36.0) / 60.0, rel=1e-6)


@pytest.mark.parametrize(("case", "stage", "seconds"), [("tiny", 2, 3000), ("tiny", 1, 1500),
                                                         ("builtin", 2, 800)])
def test_random_soak_stays_inside_before_clipping(case, stage, seconds, monkeypatch):
    data = tiny_dict()
    data["simulation"]["target_memory"] = True
    raw = []
    real = observe.observe_crew

    def spy(*args, **kwargs):
        out = real(*args, **kwargs)
        raw.append(out.copy())
        return out

    memory = []
    real_memory = observe.remembered_target

    def spy_memory(*args, **kwargs):
        out = real_memory(*args, **kwargs)
        memory.append(out)
        return out

    monkeypatch.setattr(observe, "observe_crew", spy)
    monkeypatch.setattr(observe, "remembered_target", spy_memory)
    env = cmdp_pymunk.parallel_env(case=case_from_dict(data) if case == "tiny" else None,
                                   stage=stage, seed=0, max_time_s=float(seconds))
    space = env.observation_space(env.possible_agents[0])
    rng = np.random.default_rng(1)
    returned = 0
    for seed in (0, 1):
        obs, _ = env.reset(seed=seed)
        while env.agents:
            for o in obs.values():
                assert space.contains(o)
                returned += 1
            actions = {a: tuple(int(rng.integers(n)) for n in ACTION_NVEC) for a in env.agents}
            obs, *_ = env.step(actions)
    assert returned > 1000 and len(raw) > 500
    raw = np.array(raw)
    at = env.rays.velocity_at
    # memory features are filled after observe_crew, by remembered_target
    assert (raw[:, :at + 3] >= space.low[:at + 3]).all()
    assert (raw[:, :at + 3] <= space.high[:at + 3]).all()
    memory = np.array(memory)
    assert (memory[:, 0] == 1).sum() > 100  # targets were remembered
    assert (memory >= space.low[at + 3:]).all() and (memory <= space.high[at + 3:]).all()
    assert raw[:, at + 2].max() > 0.5  # the soak really moved the crews
