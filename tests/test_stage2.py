"""Stage-2 training plumbing (not learning): config checks, the training env, the centralized
critic, a short run that writes its files, resumes and reproduces its weights, and the saved
model as an evaluator."""

import json
from pathlib import Path

import numpy as np
import pytest
import torch as th

from cmdp_pymunk.observe import CREW_FEATURES, TARGET_FEATURES
from training import stage2
from training.stage2 import Stage2Config, first_choice

DATA = Path(__file__).resolve().parent / "data"


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


def test_training_floor_appends_the_global_state_for_the_central_critic():
    config = Stage2Config(central_critic=True)
    case = stage2.training_case(config)
    floor = stage2.make_decision_loop(config, case)
    floor.reset(seed=3)
    obs = floor.observe()
    assert obs.shape == floor.low.shape and obs.dtype == np.float32
    assert np.all((obs >= floor.low) & (obs <= floor.high))
    assert np.array_equal(obs[floor.actor_size:], floor.state())
    plain = stage2.make_decision_loop(Stage2Config(central_critic=False), case)
    assert plain.low.shape == (floor.actor_size,)
    # the teacher names a target in the deciding crew's scope
    act = floor.teacher_action()
    assert first_choice(obs[:floor.actor_size], act) in \
        floor.engine.site.crews[floor.deciding].scope


def test_decisions_as_recorded_before_the_floor_moved_onto_the_engine():
    """O^e, the global state, the deciding crews and the rewards of 41 decisions on seed 3 (40
    random actions), recorded with the stage-2 env of commit fcdc414 (``Stage2Env`` over
    ``TargetEvaluationEnv`` over ``CMDPEnv``): the floor on the engine gives every float
    exactly."""
    recorded = np.load(DATA / "stage2_decisions.npz")
    config = Stage2Config(central_critic=True)
    floor = stage2.make_decision_loop(config, stage2.training_case(config))
    assert floor.actor_size == int(recorded["actor_size"])
    floor.reset(int(recorded["seed"]))
    observations, crews, rewards, times = [floor.observe()], [floor.deciding], [], \
        [floor.engine.site.time_s]
    for action in recorded["actions"]:
        out = floor.decide(action)
        assert not (out.terminated or out.truncated)
        observations.append(floor.observe())
        crews.append(floor.deciding)
        rewards.append(out.reward)
        times.append(floor.engine.site.time_s)
    np.testing.assert_array_equal(np.array(observations), recorded["observations"])
    np.testing.assert_array_equal(crews, recorded["crews"])
    np.testing.assert_array_equal(rewards, recorded["rewards"])
    np.testing.assert_array_equal(times, recorded["time_s"])


def test_central_critic_actor_ignores_the_state_and_the_lean_actor_matches():
    from stable_baselines3 import PPO

    from agents.central_critic import CentralCriticPolicy
    from agents.models import LeanActor
    from training.vec_env import FloorsVecEnv

    config = Stage2Config(central_critic=True)
    case = stage2.training_case(config)
    venv = FloorsVecEnv([lambda: stage2.make_decision_loop(config, case)])
    floor = venv.floors[0]
    model = PPO(CentralCriticPolicy, venv, n_steps=8, batch_size=8,
                policy_kwargs={"actor_size": floor.actor_size, "net_arch": [16, 16]},
                device="cpu", seed=0)
    floor.reset(seed=0)
    obs = floor.observe()
    other = obs.copy()
    other[floor.actor_size:] = np.random.default_rng(0).random(len(obs) - floor.actor_size)
    with th.no_grad():
        pair = th.as_tensor(np.stack([obs, other]))
        means = model.policy.get_distribution(pair).distribution.mean.numpy()
        values = model.policy.predict_values(pair).numpy()
    assert np.allclose(means[0], means[1])  # the actor reads O^e only
    assert not np.allclose(values[0], values[1])  # the critic reads the state too
    lean = LeanActor.from_sb3(model)
    assert lean.observation_size == floor.actor_size
    assert np.allclose(lean.act(obs[None, :floor.actor_size])[0],
                       np.clip(means[0], -1, 1), atol=1e-5)


def short_run(tmp_path, name: str, extra=()):
    argv = ["stage2", "--out", str(tmp_path / name), "--no-progress",
            "--set", "total_steps=64", "--set", "n_steps=32", "--set", "batch_size=32",
            "--set", "n_epochs=1", "--set", "bc_episodes=1", "--set", "bc_epochs=2",
            "--set", "eval_seeds=[2000]", "--set", "eval_every_steps=64",
            "--set", "checkpoint_every_steps=64", *extra]
    from training.commands.train import main

    assert main(argv) == 0
    return tmp_path / name


@pytest.mark.slow
def test_short_run_writes_its_files_resumes_and_repeats_its_weights(tmp_path):
    from stable_baselines3 import PPO

    from agents.models import ModelEvaluator
    from training.commands.simulate import main as simulate

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
        config = Stage2Config()
        floor = stage2.make_decision_loop(config, stage2.training_case(config))
        floor.reset(seed=5)
        engine, i = floor.engine, floor.deciding
        evaluator.prepare(engine.case)
        env_values.append(evaluator.values_for(engine, i))
    assert env_values[0] == env_values[1] and len(env_values[0]) > 1
    assert simulate(["--evaluator", str(run / "final_model.zip"), "--seed", "1",
                     "--max-time-s", "3000", "--no-charts", "--no-progress",
                     "--out", str(tmp_path / "sim")]) in (0, 1)
    assert (tmp_path / "sim" / "summary.json").is_file()
