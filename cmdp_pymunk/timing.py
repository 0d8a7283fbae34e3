"""Wall time per simulation stage, for benchmarks: a wrapper around an engine, not probes in it.

``clocked(engine, clock)`` turns an engine into a ``ClockedEngine`` (the same object, its class
swapped for a subclass that laps the clock around each stage of the span), on either motion:
the motion is the engine's member, not its class, so the engine's
own step carries no timing code. A clone of a clocked engine is clocked too (into a copy of
the clock).
"""

from __future__ import annotations

import time
from collections import defaultdict

from .engine import Engine


class StageClock:
    """Accumulates perf_counter laps under stage names: ``start()``, then ``lap(name)``."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)
        self._t = time.perf_counter()

    def start(self) -> None:
        self._t = time.perf_counter()

    def lap(self, stage: str) -> None:
        now = time.perf_counter()
        self.seconds[stage] += now - self._t
        self._t = now


class ClockedEngine(Engine):
    """An engine whose second is split by stage on ``self.clock`` (see ``clocked``)."""

    clock: StageClock

    def step(self, actions):
        self.clock.start()
        second = super().step(actions)
        self.clock.lap("rewards and logs")
        return second

    def _move(self, actions, span):
        super()._move(actions, span)
        self.clock.lap("motion (P_phy, Eq. 1)" if self.motion.takes_actions
                       else "motion (the walks)")

    def _construct(self, k=1):
        out = super()._construct(k)
        self.clock.lap("construction (P_cons, Eq. 2)")
        return out

    def _decide(self, ctx):
        super()._decide(ctx)
        self.clock.lap("decisions and evaluation (Table 1, Eq. 9)")


def clocked(engine: Engine, clock: StageClock) -> Engine:
    """``engine``, timing each stage of its seconds on ``clock`` from now on."""
    engine.__class__ = ClockedEngine
    engine.clock = clock
    return engine
