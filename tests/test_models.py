"""Trained models in the scripted policies' places: a freshly initialised PPO of the right
shape stands in for a trained one (this checks the plumbing, not the skill)."""

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from cmdp_pymunk import load_case
from cmdp_pymunk.observe import evaluation_size
from cmdp_pymunk.state import Site
from training import simulate

TINY = str(Path(__file__).resolve().parent.parent / "docs" / "examples" / "tiny_case.toml")


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
