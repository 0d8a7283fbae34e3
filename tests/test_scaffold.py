"""The PPO run both training stages share (training/scaffold.py): the progress bar's total is
what PPO runs."""

from types import SimpleNamespace

from training.scaffold import learn, whole_rollouts


def test_whole_rollouts_by_hand():
    # the built-in case: 7 crews x 8 env copies = 56 envs, n_steps 256 -> 14,336 a rollout;
    # 2,000 wanted -> 1 rollout; 14,337 -> 2 rollouts = 28,672; a multiple stays; 0 stays 0
    assert whole_rollouts(2_000, 256 * 56) == 14_336
    assert whole_rollouts(14_337, 14_336) == 28_672
    assert whole_rollouts(28_672, 14_336) == 28_672
    assert whole_rollouts(0, 14_336) == 0


def test_the_bar_counts_to_what_ppo_runs(tmp_path, monkeypatch):
    """SB3's PPO on a real env asked for 20 steps with rollouts of 8 runs 24: ``learn``
    asks for 24, the bar's total is 24, and the log line says why."""
    import stable_baselines3.common.callbacks as callbacks
    from stable_baselines3 import PPO

    totals = []

    class Bar:  # SB3's ProgressBarCallback makes tqdm(total=...): record the total
        def __init__(self, total):
            totals.append(total)

        def update(self, n):
            pass

        def refresh(self):
            pass

        def close(self):
            pass

    monkeypatch.setattr(callbacks, "tqdm", Bar)
    model = PPO("MlpPolicy", "CartPole-v1", n_steps=8, batch_size=8, n_epochs=1,
                policy_kwargs={"net_arch": [8]}, device="cpu", seed=0)
    lines = []
    run = SimpleNamespace(folder=tmp_path, suffix="", config=SimpleNamespace(total_steps=20),
                          log=lines.append, unit="steps", resume=None, progress_bar=True)
    learn(model, run, [])
    assert model.num_timesteps == 24 and totals == [24]
    assert lines[0].startswith("PPO: 24 steps to go (20 rounded up to whole rollouts of "
                               "n_steps 8 x 1 envs = 8)")
