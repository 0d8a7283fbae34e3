"""Figs. 12-14 (media/comparison.py) from hand-made rows: box and strip plots with the mean,
its interval and the bounds; the paper's per-seed lines broken where seeds are not consecutive."""

import numpy as np
import pytest

from media import comparison
from training.runs.paired import summarize


def rows_for(strategies: dict[str, dict[int, float | None]]) -> list[dict]:
    out = []
    for name, by_seed in strategies.items():
        for seed, makespan in by_seed.items():
            out.append({"strategy": name, "navigator": "scripted", "seed": seed,
                        "finished": makespan is not None, "makespan_s": makespan,
                        "simulated_s": makespan or 9000.0, "reaching_steps": 10 * seed,
                        "idle_blocked_by_task_area": seed, "stalled": False,
                        "timed_out": makespan is None})
    return out


ROWS = rows_for({"priority": {0: 100.0, 1: 200.0, 2: 300.0, 7: 400.0},
                 "nearest": {0: 110.0, 1: 210.0, 2: None, 7: 410.0}})


def test_consecutive_runs_and_strip_offsets():
    assert comparison.consecutive_runs([0, 1, 2, 7, 8]) == [slice(0, 3), slice(3, 5)]
    assert comparison.consecutive_runs([5]) == [slice(0, 1)]
    assert comparison.strip_offsets(1).tolist() == [0.0]
    assert comparison.strip_offsets(3, 0.2).tolist() == pytest.approx([-0.2, 0.0, 0.2])


def test_per_seed_lines_break_at_a_gap_and_tick_whole_seeds():
    fig = comparison.per_episode_plot(ROWS, "makespan_s", "makespan (s)", "Fig. 12")
    ax = fig.axes[0]
    lines = [ln for ln in ax.get_lines() if ln.get_linestyle() == "-"]
    # seeds 0-2 and 7 are two runs for each strategy: 4 lines, none from seed 2 to seed 7
    assert sorted(len(ln.get_xdata()) for ln in lines) == [1, 1, 3, 3]
    assert all(max(ln.get_xdata()) - min(ln.get_xdata()) == len(ln.get_xdata()) - 1
               for ln in lines)
    fig.canvas.draw()  # the locator picks the ticks at drawing time
    ticks = [t for t in ax.get_xticks() if ax.get_xlim()[0] <= t <= ax.get_xlim()[1]]
    assert ticks and all(float(t).is_integer() for t in ticks)


def test_strategy_plot_draws_the_mean_interval_and_bounds():
    summary = summarize(ROWS, 50.0, 80.0)
    fig = comparison.strategy_plot(ROWS, "makespan_s", "makespan (s)", "Fig. 12", summary,
                                   {"lower bound": 50.0, "CP-SAT bound": 80.0})
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_xticklabels()] == ["priority", "nearest"]
    horizontal = {ln.get_ydata()[0] for ln in ax.get_lines()
                  if len(set(ln.get_ydata())) == 1 and len(ln.get_ydata()) == 2
                  and tuple(ln.get_xdata()) == (0, 1)}
    assert {50.0, 80.0} <= horizontal  # axhline spans the axes in axes coordinates
    # the priority mean: (100 + 200 + 300 + 400) / 4 = 250, drawn as a diamond
    diamonds = [ln for ln in ax.get_lines() if ln.get_marker() == "D" and len(ln.get_xdata())]
    assert any(np.isclose(ln.get_ydata()[0], 250.0) for ln in diamonds)
    # the nearest floor that did not finish is an x at the simulated time
    assert any(ln.get_marker() == "x" and ln.get_ydata()[0] == 9000.0 for ln in ax.get_lines())
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "lower bound 50" in legend and "CP-SAT bound 80" in legend


def test_draw_comparison_writes_three_files_either_way(tmp_path):
    summary = summarize(ROWS, 50.0, None)
    for per_seed in (False, True):
        out = tmp_path / str(per_seed)
        paths = comparison.draw_comparison(ROWS, out, summary, 50.0, None, per_seed)
        assert [p.name for p in paths] == [f[0] for f in comparison.FIGURES]
        assert all(p.stat().st_size > 1000 for p in paths)
