"""``num_cpus`` means worker processes: ``ProcessGroupsVecEnv`` steps k env copies in fewer
processes, exactly as one ``DummyVecEnv`` of them would (seeds, auto-resets, infos), and stage
2 builds it from its settings; ``FloorsVecEnv`` steps k stage-2 floors as k envs would."""

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.vec_env import DummyVecEnv

import cmdp_pymunk
from agents.navigator import Navigator
from cmdp_pymunk.adapters.decision_loop import DecisionLoop, TargetEvaluationEnv
from training import stage2
from training.scaffold import vec_env
from training.vec_env import FloorsVecEnv, ProcessGroupsVecEnv


class Dice(gym.Env):
    """Episodes of 2-4 steps drawn from the env's generator; reward: a die roll plus the
    action; ``truncated`` on odd lengths, so both kinds of end occur."""

    observation_space = gym.spaces.Box(0.0, 10.0, (2,), np.float32)
    action_space = gym.spaces.Discrete(3)

    def __init__(self, name: str = "dice"):
        self.name = name

    def reset(self, seed=None, options=None):
        super().reset(seed=seed)
        self.t, self.length = 0, int(self.np_random.integers(2, 5))
        return self._obs(), {"length": self.length}

    def _obs(self):
        return np.array([self.t, self.length], np.float32)

    def step(self, action):
        self.t += 1
        end = self.t >= self.length
        reward = float(self.np_random.integers(1, 7) + action)
        return self._obs(), reward, end and self.length % 2 == 0, end and self.length % 2 == 1, \
            {"t": self.t}

    def double(self, x):
        return 2 * x


def run(venv, steps: int = 12):
    venv.seed(7)
    out = [venv.reset(), list(venv.reset_infos)]
    actions = np.random.default_rng(0).integers(0, 3, (steps, venv.num_envs))
    for a in actions:
        out.append(venv.step(a))
    venv.close()
    return out


@pytest.mark.parametrize("processes", [1, 2, 5])
def test_the_copies_step_as_in_one_process(processes):
    fns = [Dice] * 5
    grouped = ProcessGroupsVecEnv(fns, processes)
    assert len(grouped.processes) == processes and grouped.starts[-1] == 5
    for got, want in zip(run(grouped), run(DummyVecEnv(fns)), strict=True):
        if isinstance(want, tuple):  # obs, rewards, dones, infos
            for g, w in zip(got[:3], want[:3], strict=True):
                np.testing.assert_array_equal(g, w)
            for gi, wi in zip(got[3], want[3], strict=True):
                assert gi.keys() == wi.keys()
                for k in wi:
                    np.testing.assert_array_equal(gi[k], wi[k])
        elif isinstance(want, list):
            assert got == want  # reset infos
        else:
            np.testing.assert_array_equal(got, want)
    assert all(not p.is_alive() for p in grouped.processes)


def test_attributes_and_methods_reach_the_right_copies():
    names = [f"d{k}" for k in range(5)]
    venv = ProcessGroupsVecEnv([lambda k=k: Dice(names[k]) for k in range(5)], 2)
    try:
        assert venv.starts == [0, 3, 5]
        assert venv.get_attr("name") == names
        assert venv.get_attr("name", [4, 0, 3]) == ["d4", "d0", "d3"]
        venv.set_attr("name", "x", [1, 4])
        assert venv.get_attr("name") == ["d0", "x", "d2", "d3", "x"]
        assert venv.env_method("double", 21, indices=[2, 3]) == [42, 42]
        assert venv.env_is_wrapped(gym.Wrapper) == [False] * 5
        with pytest.raises(AttributeError):
            venv.get_attr("nothing")
    finally:
        venv.close()
    with pytest.raises(ValueError, match="processes = 6 must be 1 to the number of env copies"):
        ProcessGroupsVecEnv([Dice] * 5, 6)


def short_floor() -> DecisionLoop:
    """A built-in floor cut at 2,000 s: episodes of 3 decisions, so 8 steps of a vector
    cross episode ends."""
    return DecisionLoop(None, Navigator, park_idle=True, max_time_s=2000.0, with_state=True)


def lean(info: dict) -> dict:
    """An info as ``FloorsVecEnv`` gives it: ``TimeLimit.truncated`` only when true."""
    return {k: v for k, v in info.items() if k != "TimeLimit.truncated" or v}


def test_a_vector_of_floors_steps_each_as_its_own_env():
    """k floors in one ``FloorsVecEnv`` (and in two processes of them) give every floor the
    trajectory of its own ``TargetEvaluationEnv`` in a ``DummyVecEnv``: observations, rewards,
    ends, end infos, and the seeds of the episodes after the first."""
    k, steps = 3, 8
    actions = np.random.default_rng(0).uniform(-1, 1, (steps, k, 2)).astype(np.float32)

    def trace(venv):
        venv.seed(11)
        out = [venv.reset()]
        for a in actions:
            obs, rewards, dones, infos = venv.step(a)
            out.append((obs, rewards, dones, [lean(i) for i in infos]))
        venv.close()
        return out

    want = trace(DummyVecEnv([lambda: TargetEvaluationEnv(short_floor())] * k))
    assert sum(d.sum() for _, _, d, _ in want[1:]) >= k  # every floor ended at least once
    for venv in (FloorsVecEnv([short_floor] * k),
                 ProcessGroupsVecEnv([short_floor] * k, 2, vectorize=FloorsVecEnv)):
        got = trace(venv)
        np.testing.assert_array_equal(got[0], want[0])
        for (obs, rewards, dones, infos), (w_obs, w_rewards, w_dones, w_infos) in \
                zip(got[1:], want[1:], strict=True):
            np.testing.assert_array_equal(obs, w_obs)
            assert rewards.dtype == w_rewards.dtype and np.array_equal(rewards, w_rewards)
            np.testing.assert_array_equal(dones, w_dones)
            for info, w_info in zip(infos, w_infos, strict=True):
                assert info.keys() == w_info.keys()
                for key, value in w_info.items():
                    if key == "terminal_observation":
                        np.testing.assert_array_equal(info[key], value)
                    else:
                        assert info[key] == value, key


def test_scaffold_vec_env_is_in_process_for_one_cpu():
    assert isinstance(vec_env([Dice] * 3, 1), DummyVecEnv)


def test_stage2_runs_num_cpus_processes():
    tiny = str(cmdp_pymunk.TINY_CASE)
    config = stage2.Stage2Config(case=tiny, n_envs=3, num_cpus=2, central_critic=False)
    case = stage2.training_case(config)
    venv = stage2.make_vec_env(config, case, seed=4)
    try:
        assert isinstance(venv.venv, ProcessGroupsVecEnv) and len(venv.venv.processes) == 2
        obs = venv.reset()
    finally:
        venv.close()
    alone = stage2.make_vec_env(config.model_copy(update={"num_cpus": 1}), case, seed=4)
    try:
        assert isinstance(alone.venv, FloorsVecEnv)
        np.testing.assert_array_equal(alone.reset(), obs)
    finally:
        alone.close()
