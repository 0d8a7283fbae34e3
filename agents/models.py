"""Trained Stable-Baselines3 models in the places the scripted policies take.

``PolicyNavigator``: a stage-1 reaching policy (observation Box(115) or Box(119), action
MultiDiscrete([4, 3, 3])) as the low level. ``ModelEvaluator``: a stage-2 evaluation policy
(observation O^e, action Box(2), the desired position) as the target evaluator, through Eq. 4.
Both load on the CPU and act deterministically.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cmdp_pymunk.evaluate import DesiredPositionEvaluator
from cmdp_pymunk.move import STAND_STILL
from cmdp_pymunk.observe import evaluation_observation, evaluation_size


def load_model(path: str | Path):
    import torch
    from stable_baselines3 import PPO

    # Inference on a few rows a step: one thread is fastest, and the default (one per core)
    # made two simulations side by side fight over the cores (156 against 2,400 x real time
    # per episode here).
    torch.set_num_threads(1)

    try:
        return PPO.load(str(path), device="cpu")
    except Exception as err:  # SB3 raises many kinds for a file that is not its zip
        raise ValueError(f"{path}: cannot load a stable-baselines3 PPO model ({err}); "
                         "fix: give a .zip written by model.save()") from None


def _check_shape(model, expected: int, path, what: str) -> None:
    shape = model.observation_space.shape
    if shape != (expected,):
        raise ValueError(f"{path}: the model observes {shape}, but {what} needs ({expected},); "
                         "fix: use a model trained on this case and stage")


class PolicyNavigator:
    """A trained reaching policy, one set of weights shared by every crew.

    ``deterministic=False`` samples its actions (a deterministic policy can repeat the same
    blocked move forever); the samples come from torch's generator, seeded by ``reset(seed)``
    at every episode, so a run is still reproducible.
    """

    def __init__(self, path: str | Path, deterministic: bool = True):
        self.path = Path(path)
        self.model = load_model(path)
        self.deterministic = deterministic

    @classmethod
    def from_model(cls, model, deterministic: bool = True) -> PolicyNavigator:
        """Wrap a live model (e.g. during training) without a file."""
        navigator = cls.__new__(cls)
        navigator.path, navigator.model, navigator.deterministic = Path("<live>"), model, \
            deterministic
        return navigator

    def reset(self, seed: int) -> None:
        import torch

        torch.manual_seed(seed)

    def bind(self, env) -> None:
        _check_shape(self.model, env.observation_space(env.possible_agents[0]).shape[0],
                     self.path, "the reaching observation")

    def actions(self, env, observations) -> dict:
        movers = [a for a in env.agents if env.site.crews[env.agent_index[a]].moving]
        out = {a: STAND_STILL for a in env.agents}
        if movers:
            batch = np.stack([observations[a] for a in movers])
            acts, _ = self.model.predict(batch, deterministic=self.deterministic)
            out.update({a: tuple(int(v) for v in act) for a, act in zip(movers, acts,
                                                                        strict=True)})
        return out


class ModelEvaluator(DesiredPositionEvaluator):
    """A trained evaluation policy: its desired position values the targets by Eq. 4."""

    def __init__(self, path: str | Path):
        super().__init__()
        self.path = Path(path)
        self.model = load_model(path)
        self.env = None

    def bind(self, env) -> None:
        from cmdp_pymunk.state import Site

        self.env = env
        site = env.site if env.site is not None else Site(env.case, env.stage)
        _check_shape(self.model, evaluation_size(site), self.path, "the evaluation observation")

    def desired_position(self, crew, site, position) -> tuple[float, float]:
        heading = self.env.world.bodies[crew.index].angle
        obs = evaluation_observation(site, crew, position, heading)
        desired, _ = self.model.predict(obs, deterministic=True)
        desired = np.clip(desired, -1.0, 1.0)
        return float(desired[0]), float(desired[1])
