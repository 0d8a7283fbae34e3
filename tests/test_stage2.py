"""Stage-2 training plumbing (not learning): config checks, the training env, the centralized
critic, a short run that writes its files, resumes and reproduces its weights, and the saved
model as an evaluator."""

import json

import numpy as np
import pytest
import torch as th

from cmdp_pymunk.observe import CREW_FEATURES, TARGET_FEATURES
from training import stage2
from training.stage2 import Stage2Config, Stage2Env, first_choice


def observation_with(targets: list[tuple[float, float, bool]]) -> np.ndarray:
    """O^e with only the columns ``first_choice`` reads: x, y and the scope flag per target."""
    obs = np.zeros(CREW_FEATURES + TARGET_FEATURES * len(targets), np.float32)
    rows = obs[CREW_FEATURES:].reshape(len(targets), TARGET_FEATURES)
    for row, (x, y, in_scope) in zip(rows, targets, strict=True):
        row[4], row[5], row[8] = x, y, float(in_scope)
    return obs


def test_first_choice_is_the_scope_target_nearest_the_desired_position():
    obs = observation_with([(0.0, 0.0, False), (0.5, 0.5, True), (-0.5, 0.2, True)])
    # distances from (0.1, 0.1): target 0 is nearest (0.14) but out of scope; target 1:
    # hypot(0.4, 0.4) = 0.566; target 2: hypot(0.6, 0.1) = 0.608 -> target 1
    assert first_choice(obs, (0.1, 0.1)) == 1
    # from (-0.4, 0.0): target 1 hypot(0.9, 0.5) = 1.03; target 2 hypot(0.1, 0.2) = 0.22
    assert first_choice(obs, (-0.4, 0.0)) == 2


@pytest.mark.parametrize("override, message", [
    ("n_envs=1", "num_cpus = 2 exceeds n_envs = 1"),
    ("low_level='nowhere.zip'", "no such stage-1 model"),
    ("gama=0.9", "unknown setting(s) gama"),
    ("eval_seeds=[]", "eval_seeds = [] must be a non-empty list"),
    ("learning_rate=nan", "must be a finite number"),
])
def test_bad_settings_are_refused_with_their_fix(override, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")
                       .replace("[", r"\[").replace("]", r"\]")):
        Stage2Config.load(None, ["num_cpus=2", override] if "n_envs" in override
                          else [override])


def test_training_env_appends_the_global_state_for_the_central_critic():
    config = Stage2Config(central_critic=True)
    env = Stage2Env(config)
    obs, _ = env.reset(seed=3)
    assert obs.shape == env.observation_space.shape
    assert env.observation_space.contains(obs)
    assert np.array_equal(obs[env.actor_size:], env.inner.env.state())
    plain = Stage2Env(Stage2Config(central_critic=False))
    assert plain.observation_space.shape == (env.actor_size,)
    # the teacher names a target in the deciding crew's scope
    act = env.teacher_action()
    assert first_choice(obs[:env.actor_size], act) in \
        env.inner.env.site.crews[env.inner.env.agent_index[env.inner.deciding_agent]].scope


def test_central_critic_actor_ignores_the_state_and_the_lean_actor_matches():
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    from agents.central_critic import CentralCriticPolicy
    from agents.models import LeanActor

    env = Stage2Env(Stage2Config(central_critic=True))
    model = PPO(CentralCriticPolicy, DummyVecEnv([lambda: env]), n_steps=8, batch_size=8,
                policy_kwargs={"actor_size": env.actor_size, "net_arch": [16, 16]},
                device="cpu", seed=0)
    obs, _ = env.reset(seed=0)
    other = obs.copy()
    other[env.actor_size:] = np.random.default_rng(0).random(len(obs) - env.actor_size)
    with th.no_grad():
        pair = th.as_tensor(np.stack([obs, other]))
        means = model.policy.get_distribution(pair).distribution.mean.numpy()
        values = model.policy.predict_values(pair).numpy()
    assert np.allclose(means[0], means[1])  # the actor reads O^e only
    assert not np.allclose(values[0], values[1])  # the critic reads the state too
    lean = LeanActor.from_sb3(model)
    assert lean.observation_size == env.actor_size
    assert np.allclose(lean.act(obs[None, :env.actor_size])[0],
                       np.clip(means[0], -1, 1), atol=1e-5)


def short_run(tmp_path, name: str, extra=()):
    argv = ["stage2", "--out", str(tmp_path / name), "--no-progress",
            "--set", "total_steps=64", "--set", "n_steps=32", "--set", "batch_size=32",
            "--set", "n_epochs=1", "--set", "bc_episodes=1", "--set", "bc_epochs=2",
            "--set", "eval_seeds=[2000]", "--set", "eval_every_steps=64",
            "--set", "checkpoint_every_steps=64", *extra]
    from training.train import main

    assert main(argv) == 0
    return tmp_path / name


@pytest.mark.slow
def test_short_run_writes_its_files_resumes_and_repeats_its_weights(tmp_path):
    from stable_baselines3 import PPO

    from agents.models import ModelEvaluator
    from training.simulate import main as simulate

    run = short_run(tmp_path, "a")
    for name in ("config.json", "case.json", "progress.csv", "best_model.zip",
                 "final_model.zip", "behaviour_cloning.json", "training_curve.png"):
        assert (run / name).is_file(), name
    assert list((run / "checkpoints").glob("step_*.zip"))
    assert any((run / "tb").iterdir())
    progress = (run / "progress.csv").read_text()
    assert "eval/mean_makespan_s" in progress  # (no floor ends within 64 decisions, so the
    # per-episode cmdp/ metrics are not there yet)

    again = short_run(tmp_path, "b")
    a, b = PPO.load(run / "final_model.zip"), PPO.load(again / "final_model.zip")
    for (name, x), (_, y) in zip(a.policy.state_dict().items(), b.policy.state_dict().items(),
                                 strict=True):
        assert th.equal(x, y), name

    # resume: the step count goes on from the checkpoint, into a new progress file
    checkpoint = sorted((run / "checkpoints").glob("step_*.zip"))[-1]
    short_run(tmp_path, "a", ["--resume", str(checkpoint), "--set", "total_steps=128"])
    assert (run / "progress-1.csv").is_file()
    assert PPO.load(run / "final_model.zip").num_timesteps >= 128
    assert json.loads((run / "config-1.json").read_text())["resumed_from"] == str(checkpoint)

    # the saved model as an evaluator: the same values twice, and through cmdp-simulate
    env_values = []
    for _ in range(2):
        evaluator = ModelEvaluator(run / "final_model.zip")
        hl = stage2.Stage2Env(Stage2Config())
        hl.reset(seed=5)
        inner = hl.inner.env
        evaluator.bind(inner)
        i = inner.agent_index[hl.inner.deciding_agent]
        env_values.append(evaluator.target_values(inner.site.crews[i], inner.site,
                                                  inner.positions[i]))
    assert env_values[0] == env_values[1] and len(env_values[0]) > 1
    assert simulate(["--evaluator", str(run / "final_model.zip"), "--seed", "1",
                     "--max-time-s", "3000", "--no-charts", "--no-progress",
                     "--out", str(tmp_path / "sim")]) in (0, 1)
    assert (tmp_path / "sim" / "summary.json").is_file()
