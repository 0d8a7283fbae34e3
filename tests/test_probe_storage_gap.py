"""benchmarks/probe_storage_gap.py: its log readers on hand-made event logs (the probe itself
plays pymunk floors: a benchmark, docs/event-floor.md)."""

import importlib.util
from pathlib import Path

import pytest

from cmdp_pymunk.events import Event

PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "probe_storage_gap.py"
spec = importlib.util.spec_from_file_location("probe_storage_gap", PATH)
probe = importlib.util.module_from_spec(spec)
spec.loader.exec_module(probe)

STORAGES = {"ST-r": "rebars"}


def test_walks_by_hand():
    # R1 walks 0-30 to the storage, loads 30-90, walks 90-130 to task area C-1, works 130-400,
    # walks 400-410 and goes idle (broken off), walks 500-520 back to the storage
    log = [Event(0, "activity", "R1", "navigating"), Event(30, "reach", "R1", "ST-r"),
           Event(30, "activity", "R1", "fetching"), Event(90, "activity", "R1", "navigating"),
           Event(130, "reach", "R1", "C-1"), Event(130, "activity", "R1", "tasking"),
           Event(400, "activity", "R1", "navigating"), Event(410, "activity", "R1", "idle_area"),
           Event(500, "activity", "R1", "navigating"), Event(520, "reach", "R1", "ST-r"),
           Event(520, "activity", "R1", "fetching")]
    assert probe.walks(log, STORAGES) == [
        ("R1", "start", "storage rebars", "start", "ST-r", 0.0, 30.0),
        ("R1", "storage rebars", "task", "ST-r", "C-1", 90.0, 40.0),
        ("R1", "task", "broken", "C-1", "broken", 400.0, 10.0),
        ("R1", "task", "storage rebars", "C-1", "ST-r", 500.0, 20.0)]
    assert probe.stays(log, "fetching") == [("R1", 60.0)]
    assert probe.stays(log, "tasking") == [("R1", 270.0)]


def test_split_walks_by_hand():
    # pymunk: the same walk (C-1 -> ST-r) once at 40 s in the base, twice at 30 s in the
    # variant: same 2 x (30 - 40) = -20; mix: the second one at the base's 40 s, plus a walk
    # only the variant has (C-2 -> ST-r, 50 s): +90 (all: 110 - 40 = 70 = -20 + 90).
    # event: one walk 40 -> 45 s: same +5, mix 0
    def row(entry, floor, pairs):
        return {"entry": entry, "floor": floor, "seed": 1, "walk_pairs": pairs}
    key, other = "RC|task -> storage rebars|C-1|ST-r", "RC|task -> storage rebars|C-2|ST-r"
    rows = [row("base", "pymunk", {key: [1, 40.0]}),
            row("v", "pymunk", {key: [2, 60.0], other: [1, 50.0]}),
            row("base", "event", {key: [1, 40.0]}), row("v", "event", {key: [1, 45.0]})]
    text = probe.split_walks(rows, "v")
    line = next(x for x in text.splitlines() if x.startswith("| RC task"))
    assert line == "| RC task -> storage rebars | -20 | +90 | +5 | +0 |"


def test_target_kind():
    assert probe.target_kind("ST-r", STORAGES) == "storage rebars"
    assert probe.target_kind("P-11", STORAGES) == "task"
    assert probe.target_kind("C-1", {}) == "task"
    with pytest.raises(AttributeError):
        probe.target_kind(None, STORAGES)
