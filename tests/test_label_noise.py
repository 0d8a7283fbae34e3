"""The label-noise report (training/research/label_noise.py): by hand, and replayed on the tiny
case."""

import json

import numpy as np
import pytest

import cmdp_pymunk
from training.research import distill, label_noise


def test_summarize_by_hand():
    labels = {0: {"makespan_s": np.array([[100.0, 150.0], [500.0, 450.0]]),
                  "choice": np.array([0, 1])}}
    runs = {(0, "teacher"): [100, 150], (0, 0): [200, 260], (0, 1): [300, 290],
            (1, "teacher"): [500, 451], (1, 0): [400, 380], (1, 1): [410, 430]}
    keys, makespans = [], []
    for (row, future), ms in runs.items():
        for k, m in enumerate(ms):
            keys.append((0, row, future, k))
            makespans.append(float(m))
    r = label_noise.summarize(keys, makespans, labels, futures=2)
    assert (r["decisions"], r["replayed_candidates"], r["replayed_exactly"]) == (2, 4, 3)
    # best: row 0 future 0 -> 0, future 1 -> 1; row 1 future 0 -> 1, future 1 -> 0
    assert r["agree_two_futures"] == 0.0 and r["agree_teacher_future"] == 0.5
    # differences (second minus first): future 0 [60, -20], future 1 [-10, 20]
    assert r["difference_mean_s"] == [20.0, 5.0] and r["difference_sd_s"] == [40.0, 15.0]
    assert r["difference_correlation"] == -1.0 and r["signal_sd_s"] == 0.0
    # over 500 s in both futures: none (row 0: 60 and -10; row 1: -20 and 20)
    assert r["large_same_sign"] == r["large_opposite_sign"] == 0.0
    # (d0 - d1) = [70, -40]: sample variance 6,050, over 2: 3,025
    assert r["noise_sd_s"] == pytest.approx(55.0)


def test_scenario_keys_are_distinct_and_not_the_expected_paces():
    from cmdp_pymunk.streams import EXPECTED

    keys = {label_noise.scenario_key(s, r, f) for s in range(30) for r in range(200)
            for f in range(4)}
    assert len(keys) == 30 * 200 * 4 and EXPECTED not in keys


def test_the_teachers_future_from_its_spec():
    from cmdp_pymunk.streams import EXPECTED

    assert label_noise.teacher_future("lookahead:candidates=3+futures=expected") == EXPECTED
    assert label_noise.teacher_future("lookahead:candidates=3+futures=0") is None
    assert label_noise.teacher_future("lookahead:candidates=2+futures=4") is False


def test_noise_replays_the_teachers_branches_on_the_tiny_case(tmp_path, capsys):
    labels = tmp_path / "labels"
    tiny = str(cmdp_pymunk.TINY_CASE)
    assert distill.main(["noise", str(tmp_path)]) == 2  # no states: says how to make them
    assert "label --states" in capsys.readouterr().err
    assert distill.main(["label", "--case", tiny, "--seeds", "0-1", "--candidates", "2",
                         "--futures", "expected", "--states", "--out", str(labels)]) == 0
    out = tmp_path / "noise.json"
    assert distill.main(["noise", str(labels), "--every", "1", "--futures", "2",
                         "--out", str(out)]) == 0
    report = json.loads(out.read_text())
    assert distill.main(["noise", str(labels), "--every", "1", "--futures", "2",
                         "--out", str(tmp_path / "again.json")]) == 0
    assert json.loads((tmp_path / "again.json").read_text())["branches_s"] == \
        report["branches_s"]  # the same futures each run
    assert report["seeds"] == [0, 1] and report["decisions"] == 2
    assert report["replayed_exactly"] == report["replayed_candidates"] == 4
    assert report["branches"] == len(report["branches_s"]) == 2 * 2 * 3  # 2 decisions x 2
    # candidates x (teacher + 2 futures)
