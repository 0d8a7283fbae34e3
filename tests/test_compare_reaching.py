"""The issue-4 verdict table from two cmdp-simulate run folders (hand-made summaries)."""

import json

import pytest

from training.commands.compare_reaching import compare, load_run, main


def write_run(folder, rows):
    for seed, (makespan, reach) in rows.items():
        d = folder / f"seed-{seed}"
        d.mkdir(parents=True)
        (d / "summary.json").write_text(json.dumps({
            "seed": seed, "makespan_s": makespan, "tasks_finished": 87 if makespan else 80,
            "all_finished": makespan is not None, "reach_rate": reach}))


def test_ratio_and_reach_rate_decide_the_verdict(tmp_path):
    write_run(tmp_path / "nav", {0: (1000.0, 1.0), 1: (3000.0, 0.99)})
    write_run(tmp_path / "ok", {0: (1100.0, 0.96), 1: (3200.0, 0.95)})
    write_run(tmp_path / "slow", {0: (1200.0, 0.99), 1: (3300.0, 0.99)})
    nav = load_run(tmp_path / "nav")
    # mean 2150 over 2000 = 1.075; reach (0.96 + 0.95) / 2 = 0.955
    table, ok = compare(nav, load_run(tmp_path / "ok"), 1.10, 0.95)
    assert ok and "makespan ratio 1.075" in table and "reach rate 0.955" in table
    # mean 2250 over 2000 = 1.125 > 1.10
    table, ok = compare(nav, load_run(tmp_path / "slow"), 1.10, 0.95)
    assert not ok and "makespan ratio 1.125" in table
    _, ok = compare(nav, load_run(tmp_path / "ok"), 1.10, 0.96)  # 0.955 < 0.96
    assert not ok


def test_an_unfinished_episode_fails_and_bad_folders_are_named(tmp_path, capsys):
    write_run(tmp_path / "nav", {0: (1000.0, 1.0)})
    write_run(tmp_path / "stuck", {0: (None, 0.99)})
    assert main([str(tmp_path / "nav"), str(tmp_path / "stuck")]) == 1
    assert "undefined" in capsys.readouterr().out
    assert main([str(tmp_path / "nav"), str(tmp_path / "nothing")]) == 2
    assert "nothing: no seed-*/summary.json" in capsys.readouterr().err
    write_run(tmp_path / "other", {5: (1000.0, 1.0)})
    with pytest.raises(ValueError, match="different seeds"):
        compare(load_run(tmp_path / "nav"), load_run(tmp_path / "other"), 1.1, 0.95)
