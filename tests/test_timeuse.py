"""Where the time goes (``cmdp_pymunk.timeuse``), worked out by hand on conftest's event log."""

from __future__ import annotations

import pytest
from conftest import make_log

from cmdp_pymunk.timeuse import CATEGORIES, PHASES, phase_bounds, shares, time_use, totals

CREWS = {"X-1": "XC", "K-1": "KC", "M-1": "MC", "M-2": "MC"}


def test_phases_close_at_the_10_and_90_percent_finishes():
    # 4 tasks end at 130, 280, 300, 500: ceil(0.4) = the 1st closes the ramp-up, ceil(3.6) =
    # the 4th opens the tail
    assert phase_bounds([280, 130, 500, 300], 4, 500.0) == [(0, 130), (130, 500), (500, 500)]
    # an unfinished floor (2 of 4 ended): the tail starts where it stopped
    assert phase_bounds([130, 280], 4, 400.0) == [(0, 130), (130, 400), (400, 400)]
    # 20 tasks: the 2nd and the 18th finishes
    ends = [10.0 * k for k in range(1, 21)]
    assert phase_bounds(ends, 20, 200.0) == [(0, 20.0), (20.0, 180.0), (180.0, 200.0)]


def test_crew_seconds_by_type_phase_and_category_by_hand():
    use = time_use(make_log().events, CREWS, 4, 500.0)
    assert set(use) == {"XC", "KC", "MC"} and set(use["MC"]) == set(PHASES)
    nonzero = {ct: {p: {c: v for c, v in cats.items() if v} for p, cats in ph.items()}
               for ct, ph in use.items()}
    # M-1 waits for K-A until 300, walks 300-320, fetches 320-350, walks 350-370, works
    # 370-400, fetches 400-430, walks 430-440, works 440-500; M-2 waits until 300, then has no
    # target. Ramp-up 0-130, middle 130-500.
    assert nonzero["MC"] == {
        "ramp_up": {"idle_predecessor": 260.0},
        "middle": {"idle_predecessor": 340.0, "walking": 50.0, "loading": 60.0,
                   "working": 90.0, "no_target": 200.0},
        "tail": {}}
    # X-1 walks 0-10, works 10-130 and 160-280, walks 130-160, is gone from 280
    assert nonzero["XC"] == {"ramp_up": {"walking": 10.0, "working": 120.0},
                             "middle": {"walking": 30.0, "working": 120.0, "gone": 220.0},
                             "tail": {}}
    # K-1 waits for X-A until 130, walks to 160, waits for the crane 160-220, works to 300
    assert nonzero["KC"]["middle"] == {"walking": 30.0, "waiting_crane": 60.0, "working": 80.0,
                                       "gone": 200.0}
    # every crew's time is accounted for: 2 MC crews x 500 s
    assert sum(sum(c.values()) for c in use["MC"].values()) == pytest.approx(1000.0)
    assert totals(use)["MC"]["idle_predecessor"] == 600.0
    assert shares(use["KC"]["middle"])["working"] == pytest.approx(80 / 370)
    assert list(CATEGORIES)[0] == "working"


def test_the_comparison_sums_the_time_by_strategy_and_draws_it(tmp_path):
    from media.comparison import draw_time_use
    from training.runs.paired import time_use_summary, time_use_table

    use = time_use(make_log().events, CREWS, 4, 500.0)
    other = time_use(make_log().events, CREWS, 4, 400.0)  # the same log cut at 400 s
    rows = [{"strategy": "priority", "navigator": "scripted", "time_use_s": use},
            {"strategy": "priority", "navigator": "scripted", "time_use_s": other},
            {"strategy": "nearest", "navigator": "scripted"}]  # an old row: no time use
    entries = time_use_summary(rows)
    by = {(e["crew_type"], e["phase"], e["category"]): e for e in entries}
    assert {e["strategy"] for e in entries} == {"priority"}
    # MC working over the floor: 90 s (to 500) and 30 s (to 400: 370-400, then the pause),
    # mean 60
    mc = by[("MC", "floor", "working")]
    assert mc["episodes"] == 2 and mc["mean_s"] == pytest.approx(60.0)
    assert mc["ci95_low_s"] >= 0.0
    table = time_use_table(entries)
    assert table.startswith("## Where the time goes")
    assert "| priority | scripted | MC | 0.0 (0.0) |" in table  # 75 s = 0.02 h
    assert draw_time_use(entries, tmp_path / "time_use.png").stat().st_size > 5000


def test_cmdp_evaluate_writes_where_the_time_goes(tmp_path):
    from pathlib import Path

    from training.commands import evaluate_strategies as compare

    tiny = str(Path(__file__).resolve().parents[1] / "cmdp_pymunk" / "cases" / "tiny_floor.toml")
    # --workers 1: in this process, without the workers' imports (issue 43: the gate's time)
    assert compare.main(["--case", tiny, "--seeds", "0-1", "--strategies", "priority",
                         "--workers", "1", "--no-progress", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "time_use.png").stat().st_size > 5000
    assert "## Where the time goes" in (tmp_path / "summary.md").read_text()
    lines = (tmp_path / "time_use.csv").read_text().splitlines()
    assert lines[0] == ("strategy,navigator,crew_type,phase,category,episodes,mean_s,"
                        "ci95_low_s,ci95_high_s")
    assert len(lines) == 1 + 2 * 4 * len(CATEGORIES)  # 2 crew types x (floor + 3 phases)
