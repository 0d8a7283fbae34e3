"""Wall time per simulation stage, for benchmarks (off unless an env is given a clock)."""

from __future__ import annotations

import time
from collections import defaultdict


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
