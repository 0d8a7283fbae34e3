"""Trained models in the scripted policies' places: a freshly initialised PPO of the right
shape stands in for a trained one (this checks the plumbing, not the skill)."""

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

import cmdp_pymunk
from cmdp_pymunk import load_case
from cmdp_pymunk.observe import evaluation_size
from cmdp_pymunk.state import Site
from training.commands import simulate

TINY = str(cmdp_pymunk.TINY_CASE)


class Shape(gym.Env):
    def __init__(self, obs_size, action_space):
        self.observation_space = spaces.Box(-np.inf, np.inf, (obs_size,), np.float32)
        self.action_space = action_space

    def reset(self, seed=None, options=None):
        return np.zeros(self.observation_space.shape, np.float32), {}

    def step(self, action):
        return np.zeros(self.observation_space.shape, np.float32), 0.0, True, False, {}


def save_ppo(path, obs_size, action_space):
    from stable_baselines3 import PPO

    PPO("MlpPolicy", Shape(obs_size, action_space), n_steps=64, batch_size=64,
        device="cpu", seed=0).save(str(path))
    return path


def test_simulate_with_a_reaching_model_and_an_evaluation_model(tmp_path):
    navigator = save_ppo(tmp_path / "reach.zip", 115, spaces.MultiDiscrete([4, 3, 3]))
    n_eval = evaluation_size(Site(load_case(TINY), 2))
    evaluator = save_ppo(tmp_path / "eval.zip", n_eval, spaces.Box(-1, 1, (2,), np.float32))
    out = tmp_path / "run"
    code = simulate.main(["--case", TINY, "--navigator", str(navigator), "--evaluator",
                          str(evaluator), "--out", str(out), "--max-time-s", "300",
                          "--no-charts", "--no-progress"])
    assert code == 1  # an untrained policy does not finish the floor in 300 s: reported
    data = json.loads((out / "summary.json").read_text())
    assert data["navigator"].endswith("reach.zip") and data["simulated_s"] == 300
    assert 0.0 <= data["reach_rate"] <= 1.0


def test_a_model_of_the_wrong_shape_is_refused(tmp_path, capsys):
    wrong = save_ppo(tmp_path / "wrong.zip", 7, spaces.MultiDiscrete([4, 3, 3]))
    assert simulate.main(["--case", TINY, "--navigator", str(wrong), "--out",
                          str(tmp_path / "o"), "--no-progress"]) == 2
    assert "observes (7,)" in capsys.readouterr().err


def test_stochastic_model_navigator_is_reproducible(tmp_path):
    navigator = save_ppo(tmp_path / "reach.zip", 115, spaces.MultiDiscrete([4, 3, 3]))
    outs = []
    for name in ("a", "b"):
        out = tmp_path / name
        simulate.main(["--case", TINY, "--navigator", str(navigator), "--stochastic",
                       "--out", str(out), "--max-time-s", "120", "--no-charts",
                       "--no-progress"])
        outs.append((out / "events.csv").read_text())
    assert outs[0] == outs[1] and "position" in outs[0]


def test_both_low_levels_implement_the_protocol(tmp_path):
    import cmdp_pymunk
    from agents.models import PolicyNavigator
    from agents.navigator import Navigator
    from cmdp_pymunk.policy import LowLevel

    env = cmdp_pymunk.parallel_env(case=TINY)
    path = save_ppo(tmp_path / "reach.zip", 115, spaces.MultiDiscrete([4, 3, 3]))
    for low in (Navigator(), PolicyNavigator(path, deterministic=False)):
        assert isinstance(low, LowLevel)
        low.bind(env.engine)
        observations, _ = env.reset(seed=2)
        low.reset(2)
        actions = env.agent_actions(low, observations)
        assert set(actions) == set(env.agents)
        assert all(env.action_space(a).contains(np.asarray(v)) for a, v in actions.items())


def test_a_model_navigator_samples_by_default_and_deterministic_opts_into_argmax(tmp_path):
    navigator = save_ppo(tmp_path / "reach.zip", 115, spaces.MultiDiscrete([4, 3, 3]))
    modes = {}
    for name, extra in (("default", []), ("argmax", ["--deterministic"]),
                        ("alias", ["--stochastic"])):
        out = tmp_path / name
        simulate.main(["--case", TINY, "--navigator", str(navigator), "--out", str(out),
                       "--max-time-s", "60", "--no-charts", "--no-progress", *extra])
        data = json.loads((out / "summary.json").read_text())
        modes[name] = (data["navigator_sampling"], (out / "events.csv").read_text())
    assert modes["default"][0] == modes["alias"][0] == "stochastic"
    assert modes["argmax"][0] == "deterministic"
    assert modes["default"][1] == modes["alias"][1] != modes["argmax"][1]


def test_a_stuck_argmax_navigator_fails_fast_with_a_message(tmp_path, capsys):
    """An argmax policy that gets nowhere stops after 3 step caps (here 3 x 20 s), not after
    the stall guard's hour: the message names the crew, its targets and the fix."""
    import tomllib

    from agents.models import PolicyNavigator, PolicyStuck, check_not_stuck
    from cmdp_pymunk import parallel_env
    from cmdp_pymunk.cases.load import case_from_dict

    data = tomllib.loads(Path(TINY).read_text())
    data.setdefault("simulation", {})["reevaluate_after_steps"] = 20
    env = parallel_env(case=case_from_dict(data), stage=2)
    env.reset(seed=0)
    crew = next(c for c in env.engine.site.crews if c.scope)
    crew.steps_since_reach = 59
    check_not_stuck(env.engine, PolicyNavigator.stuck_after_caps)  # 59 < 60: not yet
    crew.steps_since_reach = 60
    with pytest.raises(PolicyStuck, match=f"{crew.id} has held its target.*drop "
                                          "--deterministic"):
        check_not_stuck(env.engine, PolicyNavigator.stuck_after_caps)
