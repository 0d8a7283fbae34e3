"""Rounds of approximate policy iteration (training.research.policy_iteration) and what it adds
to the distillation (training.research.distill): the gap weights by hand, label files with
any features, and the rounds on the tiny case (they resume after Ctrl-C; the same seeds give
the same weights)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import cmdp_pymunk
from agents.features import ALL_FEATURES, FEATURE_NAMES, POLICY_ITERATION_FEATURES
from training.research import distill, distill_fit, distill_labels, policy_iteration

ROOT = Path(__file__).resolve().parents[1]
TINY = str(cmdp_pymunk.TINY_CASE)
# the tiny floor: one decision a floor (an RC crew between two joints), milliseconds a floor
ROUNDS = ["--case", TINY, "--start", str(ROOT / "models" / "searched_rule.json"),
          "--teacher", "candidates=3+futures=4+race=2+floor=event", "--label-seeds", "0-3",
          "--select-seeds", "140-141"]


def test_choice_weights_by_hand():
    # gaps (max - min over the real candidates): 900 - 100 = 800, 600 - 500 = 100, 0;
    # mean 300, so the weights are 8/3, 1/3 and 0 (mean 1)
    makespan = np.array([[100.0, 900.0, np.nan], [500.0, 500.0, 600.0], [300.0, 300.0, np.nan]])
    assert distill_fit.choice_weights(makespan).tolist() == pytest.approx([8 / 3, 1 / 3, 0.0])
    assert distill_fit.choice_weights(np.array([[5.0, 5.0]])).tolist() == [0.0]  # nothing to learn


def test_gap_weighted_fit_is_the_fit_without_the_decisions_that_cost_nothing():
    # n decisions whose makespans differ by 200 s (the longest tail is best) and n whose
    # candidates all cost 1,000 s: the weights are 2 and 0 (mean 1), so the weighted loss over
    # the 2n rows is the plain loss over the n costly rows taken twice
    rng = np.random.default_rng(3)
    n, k, f = 60, 3, len(FEATURE_NAMES)
    tail = FEATURE_NAMES.index("tail")
    values = np.sort(rng.random((2 * n, k)), axis=1)[:, ::-1]
    features = rng.random((2 * n, k, f))
    features[:n, :, tail] = [0.0, 0.5, 1.0]
    makespan = np.full((2 * n, k), 1000.0)
    makespan[:n] -= 200.0 * features[:n, :, tail]
    both = {"crew_type": np.array(["FC"] * (2 * n)), "values": values, "features": features,
            "makespan_s": makespan}
    costly = {key: np.concatenate([a[:n], a[:n]]) for key, a in both.items()}
    weighted, report = distill_fit.fit_weights(both, tau_s=300.0, l2=0.1, weights="gap")
    plain, _ = distill_fit.fit_weights(costly, tau_s=300.0, l2=0.1)
    assert weighted["FC"][tail] > 0.5  # it learnt the tail
    assert weighted["FC"] == pytest.approx(plain["FC"], abs=0.01)  # L-BFGS's tolerance
    assert report["FC"]["decisions"] == 2 * n
    with pytest.raises(ValueError, match="give one of none, gap"):
        distill_fit.fit_weights(both, 300.0, 0.1, weights="size")


def _labels(path: Path, seed: int, names) -> None:
    rows = [("RC", [0.9, 0.5], np.zeros((2, len(names))), [100.0, 200.0], 0)]
    distill_labels.save_labels(path / f"seed-{seed}.npz",
                        {"seed": seed, "makespan_s": 1.0, "wall_s": 0.0, "rows": rows,
                         "candidates": 2, "features": names})


def test_label_files_name_their_features_and_must_agree(tmp_path):
    _labels(tmp_path, 0, POLICY_ITERATION_FEATURES)
    _labels(tmp_path, 1, POLICY_ITERATION_FEATURES)
    data = distill_labels.load_labels(tmp_path)
    assert data["feature_names"] == POLICY_ITERATION_FEATURES
    assert data["features"].shape == (2, 2, 15)
    _labels(tmp_path, 2, FEATURE_NAMES)
    with pytest.raises(ValueError, match="seed-2.npz has successors.*fix: fit on files of one"):
        distill_labels.load_labels(tmp_path)
    # a file from before the names were stored holds FEATURE_NAMES
    old = tmp_path / "old"
    old.mkdir()
    np.savez_compressed(old / "seed-0.npz", crew_type=np.array(["RC"]),
                        values=np.ones((1, 2)), features=np.zeros((1, 2, 11)),
                        makespan_s=np.ones((1, 2)), choice=np.zeros(1, np.int64), seed=0,
                        floor_makespan_s=1.0, wall_s=0.0)
    assert distill_labels.load_labels(old)["feature_names"] == FEATURE_NAMES


def test_label_with_a_whole_teacher_and_all_features(tmp_path, capsys):
    teacher = "candidates=3+futures=4+race=2+floor=event+base=priority"
    assert distill.main(["label", "--case", TINY, "--seeds", "0", "--teacher", teacher,
                         "--features", "all", "--out", str(tmp_path / "l")]) == 0
    data = distill_labels.load_labels(tmp_path / "l")
    assert data["teachers"] == [f"lookahead:{teacher}"]
    assert data["feature_names"] == ALL_FEATURES and data["features"].shape[2] == 27
    assert distill.main(["fit", str(tmp_path / "l"), "--weights", "gap",
                         "--out", str(tmp_path / "s.json")]) == 0
    assert json.loads((tmp_path / "s.json").read_text())["features"] == list(ALL_FEATURES)
    assert distill.main(["label", "--teacher", teacher, "--futures", "2",
                         "--out", str(tmp_path / "b")]) == 2
    assert "put candidates=K and futures=F inside it" in capsys.readouterr().err
    assert distill.main(["label", "--teacher", "candidates=3+speed=2",
                         "--out", str(tmp_path / "c")]) == 2
    assert "'speed=2' is not one of" in capsys.readouterr().err


@pytest.fixture(scope="module")
def two_rounds(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("pi") / "run"
    assert policy_iteration.main([*ROUNDS, "--out", str(out)]) == 0
    return out


def _weights(out: Path) -> list[dict]:
    return [json.loads((out / f"round-{r}" / "student.json").read_text())["weights"]
            for r in (1, 2)]


def test_two_rounds_on_the_tiny_case(two_rounds):
    out = two_rounds
    first, second = (json.loads((out / f"round-{r}" / "student.json").read_text())
                     for r in (1, 2))
    assert first["label_seeds"] == [0, 1] and second["label_seeds"] == [2, 3]
    assert second["fitted_on_seeds"] == [0, 1, 2, 3]  # --aggregate: every round's labels
    assert first["features"] == list(POLICY_ITERATION_FEATURES) and first["candidates"] == 3
    assert second["base"] == f"student:{out / 'round-1' / 'student.json'}"
    assert second["teacher"].endswith(f"race=2+floor=event+base={second['base']}")
    assert first["command"].startswith("python -m training.research.policy_iteration")
    labels = distill_labels.load_labels(out / "round-2" / "labels")
    assert labels["acting"] == [second["base"]] * 2
    assert labels["teachers"] == [second["teacher"]] * 2
    for r in (1, 2):
        report = json.loads((out / f"round-{r}" / "report.json").read_text())
        assert report["decisions"] >= 2 and set(report["agreement"]) == {"eq9", "base",
                                                                         "student"}
        assert report["student_vs_eq9"]["paired_seeds"] == 2
        assert report["eq9"]["diff_vs_eq9_mean_s"] == 0.0
    table = (out / "rounds.md").read_text().splitlines()
    assert [line.split("|")[1:3] for line in table[-2:]] == [[" 1 ", " 0-1 "],
                                                             [" 2 ", " 2-3 "]]
    # a rerun finds both rounds reported and runs nothing
    assert policy_iteration.main([*ROUNDS, "--out", str(out)]) == 0
    assert _weights(out) == [first["weights"], second["weights"]]


def test_the_same_seeds_give_the_same_labels_and_weights(two_rounds, tmp_path):
    assert policy_iteration.main([*ROUNDS, "--rounds", "2", "--out", str(tmp_path)]) == 0
    assert _weights(tmp_path) == _weights(two_rounds)
    for r, seed in ((1, 0), (2, 3)):
        a, b = (np.load(out / f"round-{r}" / "labels" / f"seed-{seed}.npz")
                for out in (two_rounds, tmp_path))
        for key in ("values", "features", "makespan_s", "choice", "floor_makespan_s"):
            assert np.array_equal(a[key], b[key], equal_nan=True), key


def test_a_round_resumes_after_ctrl_c(two_rounds, tmp_path, monkeypatch, capsys):
    save = distill_labels.save_labels

    def save_then_stop(*args, **kwargs):  # Ctrl-C once the first label floor is written
        save(*args, **kwargs)
        raise KeyboardInterrupt

    monkeypatch.setattr(distill_labels, "save_labels", save_then_stop)
    assert policy_iteration.main([*ROUNDS, "--out", str(tmp_path)]) == 130
    assert "round 1: 1 of 2 label floors" in capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "round-1").rglob("*")) == ["labels",
                                                                         "seed-0.npz"]
    monkeypatch.setattr(distill_labels, "save_labels", save)
    assert policy_iteration.main([*ROUNDS, "--out", str(tmp_path)]) == 0
    assert _weights(tmp_path) == _weights(two_rounds)


def test_bad_options_fail_before_any_floor(tmp_path, capsys):
    def fails(*extra: str, out: str = "run") -> str:
        before = sorted((tmp_path / out).rglob("*"))
        assert policy_iteration.main([*ROUNDS, *extra, "--out", str(tmp_path / out)]) == 2
        assert sorted((tmp_path / out).rglob("*")) == before  # nothing written
        return capsys.readouterr().err

    assert "--start missing.json: no such file; fix" in fails("--start", "missing.json")
    assert "leave base= out" in fails("--teacher", "candidates=3+base=priority")
    assert "'speed=2' is not one of" in fails("--teacher", "candidates=3+speed=2")
    assert "--label-seeds overlap --select-seeds (140)" in fails("--label-seeds", "139-140")
    assert "overlap the report seeds" in fails("--label-seeds", "98-101")
    assert "fix: give at least one a round" in fails("--rounds", "5")
    # a rerun with other settings in the same folder
    assert policy_iteration.main([*ROUNDS, "--rounds", "1", "--out",
                                  str(tmp_path / "once")]) == 0
    err = fails("--rounds", "1", "--l2", "3", out="once")
    assert "other settings (l2)" in err and "give a new --out" in err


def test_the_committed_student_is_a_round_of_this_code():
    """models/api_student_r2.json: round 2 of the documented run, readable by this code, and
    it plays a floor to the end (the event floor: milliseconds)."""
    from agents.student import StudentEvaluator
    from cmdp_pymunk.eventfloor import EventFloor, calibration_for

    path = ROOT / "models" / "api_student_r2.json"
    meta = json.loads(path.read_text())
    assert meta["round"] == 2 and meta["fit_weighting"] == "gap"
    assert not set(meta["fitted_on_seeds"]) & set(policy_iteration.REPORT_SEEDS)
    student = StudentEvaluator.load(path)
    assert student.features == POLICY_ITERATION_FEATURES and student.candidates == 3
    assert sorted(student.weights) == ["FC", "HIC", "JCC", "RC"]
    case = cmdp_pymunk.load_case(None)
    floor = EventFloor(case, evaluator=student, calibration=calibration_for(case))
    floor.reset(7)
    floor.run()
    assert floor.makespan_s is not None
