"""How a floor ends (training/research/floor_end.py): by-hand numbers and the command."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

import cmdp_pymunk
from training.research import floor_end as fe


def _task(kind, start, end):
    return SimpleNamespace(type=kind, started_s=start, ended_s=end)


def test_floor_end_by_hand():
    # the last R ends at 250 s, the floor at 400 s: 150 s after it; one F started after it
    # (260-400), one running at it (50-300), one done before (10-60); the F that ends last
    # took 140 s
    tasks = [_task("R", 0, 100), _task("R", 120, 250), _task("F", 50, 300),
             _task("F", 260, 400), _task("F", 10, 60), _task("HI", 0, 20)]
    assert fe.floor_end(tasks, 400.0) == {"makespan_s": 400.0, "after_last_s": 150.0,
                                          "started_after": 1, "running_at_it": 1,
                                          "last_then_duration_s": 140.0}


def test_the_command_on_the_tiny_case(tmp_path, capsys):
    out = tmp_path / "end.json"
    tiny = str(cmdp_pymunk.TINY_CASE)
    assert fe.main(["--case", tiny, "--seeds", "0-1", "--last", "HI", "--then", "R",
                    "--out", str(out)]) == 0
    assert "from the last HI task's end to the floor's end" in capsys.readouterr().out
    report = json.loads(out.read_text())
    assert [r["seed"] for r in report["rows"]] == [0, 1]
    for row in report["rows"]:
        assert 0 <= row["after_last_s"] <= row["makespan_s"]
        assert row["last_then_duration_s"] > 0
    assert report["means"]["makespan_s"] == pytest.approx(
        sum(r["makespan_s"] for r in report["rows"]) / 2)
    assert fe.main(["--case", tiny, "--last", "F", "--out", str(tmp_path / "x")]) == 2
    assert "are not the case's" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
