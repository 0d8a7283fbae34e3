"""A random-action soak through the PettingZoo API (issue 13): episodes of 3,000 steps on
random seeds, on every registered variant, record no exception, no NaN or infinite value,
no observation or state outside its space, and no crew outside the plane.

The seeds are drawn afresh each run (so the soak explores), and every failure names the
master seed and the episode's seed to replay it: ``CMDP_SOAK_SEED=N`` replays a whole run.
"""

from __future__ import annotations

import math
import os
import secrets

import numpy as np
import pettingzoo
import pytest

import cmdp_pymunk  # noqa: F401  (registers the variants)
from cmdp_pymunk.adapters.registry import VARIANTS
from cmdp_pymunk.state import CrewStatus

EPISODES = 30  # the full soak: nightly set (make test-nightly, before a release)
SAMPLE_EPISODES = 13  # the slow set (CI): every registered variant once
STEPS = 3000


def finite_numbers(value, where: str) -> None:
    """Every number in an info (nested dicts and lists) is finite."""
    if isinstance(value, dict):
        for k, v in value.items():
            finite_numbers(v, f"{where}.{k}")
    elif isinstance(value, (list, tuple)):
        for k, v in enumerate(value):
            finite_numbers(v, f"{where}[{k}]")
    elif isinstance(value, (float, np.floating)):
        assert math.isfinite(value), f"{where} = {value}"
    elif isinstance(value, np.ndarray) and value.dtype.kind == "f":
        assert np.isfinite(value).all(), where


def check_step(env, observations, rewards, infos, where: str) -> None:
    for agent, obs in observations.items():
        assert np.isfinite(obs).all(), f"{where}: {agent}'s observation is not finite"
        assert env.observation_space(agent).contains(obs), \
            f"{where}: {agent}'s observation is outside its space"
    for agent, reward in rewards.items():
        assert math.isfinite(reward), f"{where}: {agent}'s reward {reward}"
    finite_numbers(infos, f"{where}: infos")
    state = env.state()
    assert np.isfinite(state).all() and env.state_space.contains(state), \
        f"{where}: state() outside state_space"
    half_w, half_h = env.case.plane.width_m / 2, env.case.plane.height_m / 2
    for crew, body in zip(env.engine.site.crews, env.engine.world.bodies, strict=True):
        if crew.status == CrewStatus.LEFT:
            continue
        x, y = body.position
        assert math.isfinite(x) and math.isfinite(y), f"{where}: {crew.id} at ({x}, {y})"
        assert abs(x) <= half_w and abs(y) <= half_h, \
            f"{where}: {crew.id} at ({x:.2f}, {y:.2f}) outside the plane"


@pytest.mark.parametrize("episodes", [
    pytest.param(SAMPLE_EPISODES, marks=pytest.mark.slow, id="sample"),
    pytest.param(EPISODES, marks=pytest.mark.nightly, id="all")])
def test_random_actions_through_the_pettingzoo_api_break_nothing(episodes):
    master = int(os.environ.get("CMDP_SOAK_SEED", secrets.randbits(32)))
    rng = np.random.default_rng(master)
    variants = sorted(VARIANTS)
    steps = played = 0
    for k in range(episodes):
        env_id = variants[k % len(variants)]
        seed = int(rng.integers(2**31))
        where = f"CMDP_SOAK_SEED={master}, episode {k} ({env_id}, seed {seed})"
        # the time limit is pushed out so that every episode runs its 3,000 steps unless its
        # tasks all end first
        env = pettingzoo.make("parallel", env_id, max_time_s=10 * STEPS)
        observations, infos = env.reset(seed=seed)
        check_step(env, observations, {}, infos, where)
        for agent in env.possible_agents:
            env.action_space(agent).seed(int(rng.integers(2**31)))
        for step in range(STEPS):
            if not env.agents:
                break
            actions = {a: env.action_space(a).sample() for a in env.agents}
            observations, rewards, _, _, infos = env.step(actions)
            check_step(env, observations, rewards, infos, f"{where}, step {step}")
            steps += 1
        played += 1
        env.close()
    assert played == episodes and steps >= episodes * STEPS * 0.9, (played, steps)
