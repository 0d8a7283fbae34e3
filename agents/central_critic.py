"""A centralized critic for the stage-2 policy, as the paper's MAPPO (section 4.1).

The observation a training env returns is O^e followed by the global state s
(``cmdp_pymunk.adapters.global_state``). The actor sees only O^e: its features extractor zeroes
the state part (``ActorView``), so its first layer's weights for those inputs never receive a
gradient and never matter. The critic sees all of it. Keeping one observation vector (rather
than a dict) keeps SB3's PPO, its rollout buffer and our ``LeanActor`` unchanged:
``LeanActor.from_sb3`` keeps only the first layer's O^e rows, so a deployed evaluator needs O^e
alone.
"""

from __future__ import annotations

import torch as th
from gymnasium import spaces
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor, FlattenExtractor


class ActorView(BaseFeaturesExtractor):
    """The first ``actor_size`` floats of the observation as they are, the rest zeroed."""

    def __init__(self, observation_space: spaces.Box, actor_size: int):
        size = int(observation_space.shape[0])
        if not 0 < actor_size <= size:
            raise ValueError(f"ActorView: actor_size {actor_size} outside 1..{size}")
        super().__init__(observation_space, size)
        self.actor_size = actor_size
        mask = th.zeros(size)
        mask[:actor_size] = 1.0
        self.register_buffer("mask", mask)

    def forward(self, observations: th.Tensor) -> th.Tensor:
        return observations.flatten(1) * self.mask


class CentralCriticPolicy(ActorCriticPolicy):
    """``ActorCriticPolicy`` whose actor reads O^e only and whose critic reads O^e + s.

    ``actor_size``: the length of O^e at the head of the observation.
    """

    def __init__(self, *args, actor_size: int, **kwargs):
        self._actor_size = actor_size
        self._extractors_made = 0
        kwargs["share_features_extractor"] = False
        super().__init__(*args, **kwargs)

    def make_features_extractor(self) -> BaseFeaturesExtractor:
        # SB3 makes the actor's extractor first, then the critic's (share_features_extractor
        # False): the first is the actor's masked view, the second sees everything.
        self._extractors_made += 1
        if self._extractors_made == 1:
            return ActorView(self.observation_space, self._actor_size)
        return FlattenExtractor(self.observation_space)

    def _get_constructor_parameters(self) -> dict:
        data = super()._get_constructor_parameters()
        data["actor_size"] = self._actor_size
        return data
