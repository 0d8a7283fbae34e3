"""benchmarks/probe_reorder_gap.py: its log readers on hand-made event logs (the probe itself
plays pymunk floors: a benchmark, docs/event-floor.md)."""

import importlib.util
from pathlib import Path

import pytest

from cmdp_pymunk.events import Event

PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "probe_reorder_gap.py"
spec = importlib.util.spec_from_file_location("probe_reorder_gap", PATH)
probe = importlib.util.module_from_spec(spec)
spec.loader.exec_module(probe)


def test_loading_overlap_by_hand():
    # R1 loads 10-50, R2 loads 30-70 and 90-100, R3 (another material) loads 0-100:
    # two R-crews load at once only over 30-50, i.e. 20 s
    log = [Event(0, "activity", "R3", "fetching"), Event(10, "activity", "R1", "fetching"),
           Event(30, "activity", "R2", "fetching"), Event(50, "activity", "R1", "tasking"),
           Event(70, "activity", "R2", "navigating"), Event(90, "activity", "R2", "fetching"),
           Event(100, "activity", "R2", "tasking"), Event(100, "activity", "R3", "tasking")]
    assert probe.loading_overlap(log, {"R1", "R2"}) == pytest.approx(20.0)
    assert probe.loading_overlap(log, {"R1", "R2", "R3"}) == pytest.approx(20 + 40 + 10)


def test_crane_waits_by_hand():
    # a lift asked at 0 done at 300 (240 s lift: waited 60); an assist asked at 100 done at
    # 280 (180 s: waited 0)
    log = [Event(0, "crane_request", "R1", "ST-r", "material"),
           Event(100, "crane_request", "H1", "HI-1", "task"),
           Event(280, "crane_done", "H1", "HI-1", "task"),
           Event(300, "crane_done", "R1", "ST-r", "material")]
    assert probe.crane_waits(log, 240.0, 180.0) == {"material": (1, 60.0), "task": (1, 0.0)}
