"""What the simulation needs from the policies outside it: two small protocols.

``LowLevel``: the reaching policy of section 3.6.2 (the scripted ``agents.navigator.Navigator``
or the trained ``agents.models.PolicyNavigator``): ``bind(env)`` once to the env it drives,
``reset(seed)`` at every episode (after the env's reset), and ``actions(env, observations)``
every step: a reaching action (``MultiDiscrete([4, 3, 3])``) per agent.

``TargetEvaluator`` (``evaluate``): V_Tar for a crew's target scope, ``target_values(crew, site,
position)``; the priority heuristic, GA priorities, a plan, or the stage-2 model through Eq. 4.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from .evaluate import TargetEvaluator


@runtime_checkable
class LowLevel(Protocol):
    """A reaching policy for every crew of one env (see the module doc)."""

    def bind(self, env: Any) -> None:
        """Drive ``env`` from now on (check that the policy fits its spaces)."""

    def reset(self, seed: int) -> None:
        """A new episode with this seed (seed any sampling here)."""

    def actions(self, env: Any, observations: dict) -> dict:
        """A reaching action per agent of ``env.agents`` for this step."""


__all__ = ["LowLevel", "TargetEvaluator"]
