"""The numpy actor (``agents.models.LeanActor``) against SB3's own policy: the same
distribution parameters, the same deterministic actions, reproducible seeded samples that
follow the same distribution."""

from pathlib import Path

import numpy as np
import pytest
import torch
from gymnasium import spaces

from agents.models import LeanActor, PolicyNavigator
from tests.test_models import Shape

ROOT = Path(__file__).resolve().parent.parent
COMMITTED = ROOT / "models" / "stage1_reaching.zip"


def random_ppo(obs_size, action_space, activation=None, seed=0):
    """A PPO of our shape with weights spread wide (a fresh one's action layer is scaled by
    0.01, which leaves the logits nearly tied and tests nothing)."""
    from stable_baselines3 import PPO

    kwargs = {"net_arch": [32, 16]}
    if activation is not None:
        kwargs["activation_fn"] = activation
    model = PPO("MlpPolicy", Shape(obs_size, action_space), n_steps=64, batch_size=64,
                device="cpu", seed=seed, policy_kwargs=kwargs)
    gen = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        for p in model.policy.parameters():
            p.copy_(torch.randn(p.shape, generator=gen) * 0.5)
    return model


def observations(size, n=500, seed=1):
    return np.random.default_rng(seed).normal(0.0, 1.0, (n, size)).astype(np.float32)


@pytest.mark.parametrize("activation", [None, torch.nn.ReLU])
def test_multidiscrete_logits_and_argmax_match_sb3(activation):
    model = random_ppo(9, spaces.MultiDiscrete([4, 3, 3]), activation)
    actor = LeanActor.from_sb3(model)
    obs = observations(9)
    with torch.no_grad():
        dist = model.policy.get_distribution(torch.as_tensor(obs))
    torch_logits = torch.cat([d.logits for d in dist.distribution], dim=1).numpy()
    np.testing.assert_allclose(actor.distribution(obs), torch_logits, atol=1e-5)
    expected, _ = model.predict(obs, deterministic=True)
    np.testing.assert_array_equal(actor.act(obs, deterministic=True), expected)


def test_box_mean_std_and_deterministic_action_match_sb3():
    box = spaces.Box(-1.0, 1.0, (2,), np.float32)
    model = random_ppo(7, box)
    actor = LeanActor.from_sb3(model)
    obs = observations(7)
    with torch.no_grad():
        dist = model.policy.get_distribution(torch.as_tensor(obs)).distribution
    np.testing.assert_allclose(actor.distribution(obs), dist.mean.numpy(), atol=1e-5)
    np.testing.assert_allclose(np.broadcast_to(actor.std, dist.stddev.shape),
                               dist.stddev.numpy(), rtol=1e-6)
    expected, _ = model.predict(obs, deterministic=True)
    ours = actor.act(obs, deterministic=True)
    assert (np.abs(dist.mean.numpy()) > 1).any()  # some means lie outside: clipping is tested
    np.testing.assert_allclose(ours, expected, atol=1e-5)
    assert ours.min() >= -1.0 and ours.max() <= 1.0


def test_seeded_sampling_is_reproducible_and_follows_the_distribution():
    model = random_ppo(9, spaces.MultiDiscrete([4, 3, 3]))
    actor = LeanActor.from_sb3(model)
    obs = np.repeat(observations(9, n=1), 40_000, axis=0)
    a = actor.act(obs, deterministic=False, rng=np.random.default_rng(5))
    b = actor.act(obs, deterministic=False, rng=np.random.default_rng(5))
    c = actor.act(obs, deterministic=False, rng=np.random.default_rng(6))
    np.testing.assert_array_equal(a, b)
    assert (a != c).any()
    probs = np.exp(actor.distribution(obs[:1])[0])
    start = 0
    for k, n in enumerate((4, 3, 3)):
        freq = np.bincount(a[:, k], minlength=n) / len(a)
        # 40,000 draws: the standard error of a frequency is at most 0.0025
        np.testing.assert_allclose(freq, probs[start:start + n], atol=0.012)
        start += n


def test_gaussian_sampling_is_seeded_with_the_policy_std():
    box = spaces.Box(-10.0, 10.0, (2,), np.float32)
    model = random_ppo(7, box)
    actor = LeanActor.from_sb3(model)
    obs = np.repeat(observations(7, n=1), 40_000, axis=0)
    a = actor.act(obs, deterministic=False, rng=np.random.default_rng(3))
    np.testing.assert_array_equal(a, actor.act(obs, False, np.random.default_rng(3)))
    mean = actor.distribution(obs[:1])[0]
    np.testing.assert_allclose(a.mean(axis=0), mean, atol=0.05)
    np.testing.assert_allclose(a.std(axis=0), actor.std, rtol=0.03)


def test_sampling_without_a_generator_is_refused():
    actor = LeanActor.from_sb3(random_ppo(9, spaces.MultiDiscrete([4, 3, 3])))
    with pytest.raises(ValueError, match="numpy Generator"):
        actor.act(observations(9, n=2), deterministic=False)


def test_committed_model_argmax_matches_sb3_on_real_observations():
    import cmdp_pymunk

    navigator = PolicyNavigator(COMMITTED, deterministic=True)
    env = cmdp_pymunk.parallel_env(seed=0)
    observations_, _ = env.reset(seed=0)
    navigator.reset(0)
    rows = []
    for _ in range(60):
        rows += [observations_[a] for a in env.agents]
        observations_, *_ = env.step(env.agent_actions(navigator, observations_))
    batch = np.stack(rows)
    expected, _ = navigator.model.predict(batch, deterministic=True)
    np.testing.assert_array_equal(navigator.actor.act(batch, True), expected)
