"""What the simulation needs from the policies outside it: two small protocols.

``LowLevel``: the reaching policy of section 3.6.2 (the scripted ``agents.navigator.Navigator``
or the trained ``agents.models.PolicyNavigator``): ``bind(env)`` once to the engine (or the
env over one) it drives, ``reset(seed)`` at every episode (after the engine's reset), and every
second a reaching action (``MultiDiscrete([4, 3, 3])``) per crew: ``crew_actions(engine,
observations)`` by crew index (the stage-2 env, ``highlevel``), or ``actions(env,
observations)`` by agent name (the PettingZoo env's). ``reads_rays`` says whether it reads the
crews' ray observations (``observe.ReachingObservations``); one that reads the state instead
lets the caller skip the rays.

``TargetEvaluator`` (``evaluate``): V_Tar for a crew's target scope, ``target_values(crew, site,
position)``; the priority heuristic, GA priorities, a plan, or the stage-2 model through Eq. 4.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from .evaluate import TargetEvaluator


@runtime_checkable
class LowLevel(Protocol):
    """A reaching policy for every crew of one floor (see the module doc)."""

    reads_rays: bool

    def bind(self, env: Any) -> None:
        """Drive ``env`` (an engine, or an env over one) from now on (check that the policy
        fits its case)."""

    def reset(self, seed: int) -> None:
        """A new episode with this seed (seed any sampling here)."""

    def crew_actions(self, engine: Any, observations: list | None) -> list:
        """A reaching action per crew, in crew order, for this second; ``observations``: the
        crews' reaching observations in crew order (None when ``reads_rays`` is false)."""

    def actions(self, env: Any, observations: dict) -> dict:
        """A reaching action per agent of ``env.agents`` for this step."""


__all__ = ["LowLevel", "TargetEvaluator"]
