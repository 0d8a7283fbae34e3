"""What the simulation needs from the policies outside it: one small protocol per role.

``LowLevel``: the reaching policy of section 3.6.2 (the scripted ``agents.navigator.Navigator``
or the trained ``agents.models.PolicyNavigator``). It drives an engine by crew index:
``bind(engine)`` checks that it fits the engine's case, ``reset(seed)`` starts an episode
(after the engine's reset; seed any sampling there), and ``actions(engine, observations)``
gives every second a reaching action (``MultiDiscrete([4, 3, 3])``) per crew, in crew order;
``observations`` are the crews' reaching observations in crew order
(``observe.ReachingObservations``), or None when ``reads_rays`` is false (one that reads the
state instead lets the caller skip the rays). State it keeps for one episode goes into
``engine.memory[name]``: then ``Engine.clone`` carries it, and the same low level drives a
branch of the floor (the lookahead) as it would the floor itself. The PettingZoo env maps
agent names in one helper (``CMDPEnv.agent_actions``).

``ShowsWay``: a low level that can also say where a crew means to walk (``way(engine, i)``,
the scripted navigator's planned cells), drawn on a stalled run's picture.

``TargetEvaluator`` (``evaluate``): V_Tar for a crew's target scope, ``values_for(engine, i)``;
the priority heuristic, GA priorities, a plan, the lookahead, or the stage-2 model.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from .evaluate import TargetEvaluator


@runtime_checkable
class LowLevel(Protocol):
    """A reaching policy for every crew of one floor (see the module doc)."""

    reads_rays: bool

    def bind(self, engine: Any) -> None:
        """Check that the policy fits ``engine``'s case (a ValueError naming the fix)."""

    def reset(self, seed: int) -> None:
        """A new episode with this seed (seed any sampling here)."""

    def actions(self, engine: Any, observations: list | None) -> list:
        """A reaching action per crew, in crew order, for this second; crews that need no
        decision may get anything (``move.STAND_STILL`` is customary)."""


@runtime_checkable
class ShowsWay(Protocol):
    """A low level that can say where a crew means to walk (the stall report's picture)."""

    def way(self, engine: Any, i: int) -> list[tuple[float, float]]:
        """The points (m) crew ``i`` means to walk from where it stands; empty if none."""


def best_target(crew) -> int:
    """The target of highest V_Tar in the crew's scope (lowest index on ties), or -1: the one
    every low level heads for, and where a crew walks on the event floor."""
    if not crew.values:
        return -1
    return max(crew.values, key=lambda t: (crew.values[t], -t))


__all__ = ["LowLevel", "ShowsWay", "TargetEvaluator", "best_target"]
