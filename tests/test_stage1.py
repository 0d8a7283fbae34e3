"""Stage-1 training plumbing on a few thousand steps (it does not pretend to test learning:
the committed model and its evaluation show that)."""

import json

import pytest

import cmdp_pymunk
from training import stage1
from training.commands.train import main

TINY = str(cmdp_pymunk.TINY_CASE)
# 1,024 agent-steps = two rollouts of 128 steps x 2 copies x the tiny case's 2 crews, with one
# evaluation and one checkpoint: every part of the plumbing runs once (issue 43: the gate's time)
SMALL = ["--set", f"case='{TINY}'", "--set", "total_steps=1024", "--set", "n_envs=2",
         "--set", "num_cpus=1", "--set", "n_steps=128", "--set", "batch_size=256",
         "--set", "n_epochs=1", "--set", "bc_samples=600", "--set", "bc_epochs=1",
         "--set", "eval_every_steps=1024", "--set", "checkpoint_every_steps=1024",
         "--set", "eval_seeds=[5]", "--set", "episode_time_s=200",
         # full-CMDP episodes mixed in from the start, short, so that the plumbing runs them
         "--set", "stage2_share=0.5", "--set", "stage2_after_steps=0",
         "--set", "stage2_episode_time_s=300", "--no-progress"]


def weights(path):
    from stable_baselines3 import PPO

    params = PPO.load(str(path), device="cpu").policy.state_dict()
    return {k: v.clone() for k, v in params.items()}


def test_train_checkpoint_evaluate_and_resume(tmp_path):
    run = tmp_path / "run"
    assert main(["stage1", "--out", str(run), *SMALL]) == 0
    for name in ("config.json", "case.json", "progress.csv", "final_model.zip",
                 "best_model.zip", "best.json", "training_curve.png"):
        assert (run / name).exists(), name
    assert list((run / "tb").iterdir()), "no TensorBoard log"
    checkpoints = sorted((run / "checkpoints").glob("step_*.zip"))
    assert checkpoints
    header = (run / "progress.csv").read_text().splitlines()[0]
    for metric in ("cmdp/reach_rate", "cmdp/steps_per_reach", "cmdp/collisions_per_reach",
                   "cmdp/congestion_entries_per_reach", "eval/reach_rate"):
        assert metric in header, metric
    config = json.loads((run / "config.json").read_text())
    assert config["config"]["total_steps"] == 1024 and config["versions"]["pymunk"]

    # resume from the last checkpoint with a larger budget: the step count goes on
    from stable_baselines3 import PPO

    start = PPO.load(str(checkpoints[-1]), device="cpu").num_timesteps
    assert main(["stage1", "--out", str(run), "--resume", str(checkpoints[-1]),
                        *SMALL, "--set", "total_steps=2048"]) == 0
    resumed = PPO.load(str(run / "final_model.zip"), device="cpu").num_timesteps
    assert start < resumed and resumed >= 2048
    # the first part's history and config stay; the resumed part adds its own files
    assert json.loads((run / "config.json").read_text())["resumed_from"] is None
    assert json.loads((run / "config-1.json").read_text())["resumed_from"].endswith(".zip")
    first = (run / "progress.csv").read_text().splitlines()
    second = (run / "progress-1.csv").read_text().splitlines()
    assert len(first) > 1 and len(second) > 1
    assert "score" in json.loads((run / "best.json").read_text())


@pytest.mark.slow
def test_same_seed_gives_the_same_weights(tmp_path):
    import torch

    for name in ("a", "b"):
        assert main(["stage1", "--out", str(tmp_path / name), *SMALL]) == 0
    a, b = weights(tmp_path / "a" / "final_model.zip"), weights(tmp_path / "b" /
                                                                 "final_model.zip")
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_bad_config_exits_2(tmp_path, capsys):
    assert main(["stage1", "--out", str(tmp_path), "--set", "nonsense=1"]) == 2
    assert "unknown setting" in capsys.readouterr().err
    assert main(["stage1", "--out", str(tmp_path), "--resume",
                        str(tmp_path / "missing.zip")]) == 2
    assert main(["stage1", "--out", str(tmp_path), "--set", "eval_seeds=5"]) == 2
    assert "eval_seeds" in capsys.readouterr().err
    assert main(["stage1", "--out", str(tmp_path), "--set", "eval_every_steps=0"]) == 2
    assert "must be positive" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    bad.write_text("seed = [")
    assert main(["stage1", "--config", str(bad), "--out", str(tmp_path)]) == 2
    assert "bad.toml" in capsys.readouterr().err


def test_training_curve_from_progress_csv(tmp_path):
    from media.curves import draw_training_curve, read_progress

    csv = tmp_path / "progress.csv"
    csv.write_text("time/total_timesteps,rollout/ep_rew_mean,cmdp/reach_rate,eval/reach_rate\n"
                   "1000,1.0,0.5,\n2000,2.0,0.6,0.7\n3000,2.5,,\n")
    series = read_progress(csv)
    assert series["rollout/ep_rew_mean"] == [(1000, 1.0), (2000, 2.0), (3000, 2.5)]
    assert series["eval/reach_rate"] == [(2000, 0.7)]
    png = draw_training_curve(csv, tmp_path / "curve.png")
    assert png.stat().st_size > 2000
    with pytest.raises(ValueError, match="total_timesteps"):
        bad = tmp_path / "bad.csv"
        bad.write_text("a,b\n1,2\n")
        read_progress(bad)


def test_mixed_stage_env_mixes_in_stage2_after_its_start_step():
    config = stage1.Stage1Config(n_envs=2, episode_time_s=50.0, stage2_share=1.0,
                                 stage2_after_steps=100, stage2_episode_time_s=70.0)
    case = cmdp_pymunk.load_case(None)
    n_crews = len(case.crews)
    env = stage1.MixedStageEnv(config, case)
    env.reset(seed=3)
    assert (env.stage, env.max_time_s) == (1, 50.0)  # 0 agent-steps < 100
    for _ in range(8):  # 8 calls x 2 copies x 7 crews = 112 agent-steps of the run
        env.step({})
    assert env.run_steps == 8 * 2 * n_crews
    env.reset()
    assert (env.stage, env.max_time_s) == (2, 70.0)
    assert env.engine.site.stage == 2
    resumed = stage1.MixedStageEnv(config, case, start_steps=1_000)
    resumed.reset(seed=3)
    assert resumed.stage == 2
    half = stage1.MixedStageEnv(stage1.Stage1Config(stage2_share=0.5), case)
    stages = {half.reset(seed=s) and half.stage for s in range(40)}
    assert stages == {1, 2}  # both drawn
    with pytest.raises(ValueError, match="stage2_share = 1.5 is a share of the episodes"):
        stage1.Stage1Config.load(None, ["stage2_share=1.5"])
