"""``cmdp-evaluate``'s episodes as they were before the protocol and rooms rework (issue 29):
``tests/data/golden_evaluate_tiny.csv`` was written by commit a316774's ``cmdp-evaluate`` (then
``training.evaluate``) on the tiny case, seeds 0-3, for Eq. 9, nearest, uniform and the
lookahead seeing the true durations; every column but the wall time must come back the same."""

from __future__ import annotations

import csv
from pathlib import Path

from training.commands import evaluate_strategies as compare

GOLDEN = Path(__file__).resolve().parent / "data" / "golden_evaluate_tiny.csv"
TINY = str(Path(__file__).resolve().parents[1] / "cmdp_pymunk" / "cases" / "tiny_floor.toml")


def test_cmdp_evaluate_gives_the_golden_episodes(tmp_path):
    # In this process (--workers 1; the default, every core, was 1 on a one-core machine
    # anyway): spawning workers costs their imports, seconds of the gate (issue 43). That
    # the number of workers changes no episode is test_backends' and test_evaluate's
    # test_two_workers_give_the_same_episodes (slow).
    assert compare.main(["--case", TINY, "--seeds", "0-3", "--strategies",
                         "priority,nearest,uniform,lookahead:candidates=2+futures=0",
                         "--workers", "1", "--no-progress", "--out", str(tmp_path)]) == 0
    with open(GOLDEN, newline="") as f:
        golden = list(csv.DictReader(f))
    with open(tmp_path / "episodes.csv", newline="") as f:
        now = [{k: row[k] for k in golden[0]} for row in csv.DictReader(f)]
    assert len(golden) == 16
    assert now == golden
