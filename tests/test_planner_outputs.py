"""Outputs a planner can forward (issue 31, item 6): P80/P90 from too few floors are flagged,
intervals of counts stop at 0, durations read in hours too. Numbers by hand."""

from __future__ import annotations

import pytest

from cmdp_pymunk.report import (
    MIN_FLOORS_FOR_PERCENTILES,
    makespan_stats,
    percentiles_note,
    seconds_and_hours,
)
from media.comparison import _error_bar
from training.runs.paired import count_interval, markdown_table, summarize


def test_a_duration_reads_in_seconds_and_hours():
    assert seconds_and_hours(33943) == "33,943 s (9.43 h)"  # 33943 / 3600 = 9.4286
    assert seconds_and_hours(5400.0) == "5,400 s (1.50 h)"


def test_percentiles_from_fewer_than_20_floors_are_flagged():
    assert MIN_FLOORS_FOR_PERCENTILES == 20
    assert percentiles_note(20) == "" and percentiles_note(200) == ""
    assert "from 3 finished floors (fewer than 20)" in percentiles_note(3)
    assert "from 1 finished floor (" in percentiles_note(1)
    rows = [{"makespan_s": m, "reach_rate": 1.0} for m in (100.0, 200.0, 300.0)]
    assert "3 finished floors" in makespan_stats(rows)["percentiles_note"]
    rows = [{"makespan_s": 100.0 + k, "reach_rate": 1.0} for k in range(20)]
    assert makespan_stats(rows)["percentiles_note"] == ""


def test_a_count_interval_stops_at_zero():
    assert count_interval(10.0, 25.0) == (0.0, 35.0)  # 10 - 25 < 0: clipped
    assert count_interval(100.0, 20.0) == (80.0, 120.0)
    assert count_interval(None, None) == (None, None) and count_interval(5.0, None) == (None, None)


def _row(strategy: str, seed: int, makespan: float, idle_area: int) -> dict:
    return {"strategy": strategy, "navigator": "scripted", "seed": seed, "finished": True,
            "stalled": False, "timed_out": False, "makespan_s": makespan,
            "reaching_steps": 100, "idle_waiting_for_predecessor": 0,
            "idle_blocked_by_task_area": idle_area, "idle_no_target": 0, "crane_waits": 1,
            "crane_wait_s": 10}


def test_the_comparison_clips_count_intervals_and_flags_few_floors():
    # idle counts 0, 0, 9000: mean 3000, sample sd sqrt((2 * 3000^2 + 6000^2) / 2) = 5196.2,
    # t(0.975, 2) = 4.3027: half-width 4.3027 * 5196.2 / sqrt(3) = 12,908 -> the t-interval
    # would reach -9,908; clipped at 0
    rows = [_row("priority", s, 1000.0 + s, a) for s, a in enumerate((0, 0, 9000))]
    entry = summarize(rows, 500.0, None)[0]
    assert entry["idle_blocked_by_task_area_mean"] == pytest.approx(3000.0)
    assert entry["idle_blocked_by_task_area_ci95"] == pytest.approx(12908, abs=1)
    assert entry["idle_blocked_by_task_area_ci95_low"] == 0.0
    assert entry["idle_blocked_by_task_area_ci95_high"] == pytest.approx(15908, abs=1)
    assert "3 finished floors" in entry["percentiles_note"]
    table = markdown_table([entry], 500.0, None)
    assert "P80/P90 rest on fewer than 20 finished floors for priority" in table
    # the figure's error bar: 3000 below (to 0), the half-width above
    below, above = _error_bar(entry, "idle_blocked_by_task_area_mean",
                              "idle_blocked_by_task_area_ci95")
    assert below == [pytest.approx(3000.0)] and above == [pytest.approx(12908, abs=1)]
    # the makespan keeps its symmetric interval (no _low key)
    below, above = _error_bar(entry, "makespan_mean_s", "makespan_ci95_s")
    assert below == above
