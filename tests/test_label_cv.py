"""Seed-fold cross-validation of the student on labels (training/research/label_cv.py)."""

import json

import numpy as np

from agents.features import FEATURE_NAMES
from training.research import distill_labels, label_cv


def write_labels(folder, floors=12, decisions=25, seed=0):
    """Label files whose teacher prefers the candidate with the longest tail (2,000 s for a
    tail of 1), with Eq. 9's V' unrelated to it."""
    rng = np.random.default_rng(seed)
    folder.mkdir()
    tail = FEATURE_NAMES.index("tail")
    for s in range(floors):
        values = np.sort(rng.random((decisions, 3)), axis=1)[:, ::-1]
        features = rng.random((decisions, 3, len(FEATURE_NAMES)))
        makespan = 30000.0 - 2000.0 * features[:, :, tail] + rng.normal(0, 50, (decisions, 3))
        np.savez(folder / f"seed-{s}.npz", crew_type=np.array(["FC", "RC"] * (decisions // 2)
                                                            + ["FC"] * (decisions % 2)),
                 values=values, features=features, makespan_s=makespan,
                 choice=makespan.argmin(axis=1), seed=s, wall_s=1.0, teacher="synthetic",
                 acting="priority", feature_names=np.array(FEATURE_NAMES))


def test_the_student_gains_on_held_out_floors_and_eq9_gains_nothing(tmp_path):
    write_labels(tmp_path / "l")
    data = distill_labels.load_labels(tmp_path / "l")
    folds = label_cv.seed_folds(data["seeds"], 4)
    assert sorted(np.concatenate(folds).tolist()) == list(range(12))
    student = label_cv.summary(label_cv.floor_gains(
        data, folds, lambda train: label_cv.linear_scorer(train, pooled=False)))
    # a pick by V' alone is Eq. 9's pick: exactly 0 on every floor
    eq9 = label_cv.floor_gains(data, folds, lambda train: lambda test: np.nan_to_num(
        test["values"]))
    assert set(eq9.values()) == {0.0}
    # E[gap] of a random pick against the best of 3 uniform tails: 2,000 x (3/4 - 1/2) = 500 s
    assert student["mean_s"] < -300 and student["floors"] == 12
    best = label_cv.noisy_best(data)
    assert best["mean_s"] <= student["mean_s"]
    # one weight vector for both types learns the same shared preference
    pooled = label_cv.summary(label_cv.floor_gains(
        data, folds, lambda train: label_cv.linear_scorer(train, pooled=True), pooled=True))
    assert pooled["mean_s"] < -300


def test_the_command_writes_its_report_and_refuses_bad_options(tmp_path, capsys):
    write_labels(tmp_path / "l", floors=6, decisions=10)
    out = tmp_path / "cv.json"
    assert label_cv.main([str(tmp_path / "l"), "--folds", "3", "--fractions", "0.5,1",
                          "--features", "tail,nearness", "--out", str(out)]) == 0
    report = json.loads(out.read_text())
    assert [r["fraction"] for r in report["curve"]] == [0.5, 1.0]
    assert report["features"] == ["tail", "nearness"] and report["floors"] == 6
    assert label_cv.main([str(tmp_path / "l"), "--folds", "7"]) == 2
    assert "give 2 to 6" in capsys.readouterr().err
    assert label_cv.main([str(tmp_path / "l"), "--features", "binding"]) == 2


def write_student(path, weights, features=("tail",)):
    from agents.student import StudentEvaluator
    StudentEvaluator(weights, 3, features).save(path, {})


def test_base_scores_are_the_students_and_a_pick_as_the_base_gains_nothing(tmp_path):
    write_labels(tmp_path / "l", floors=8, decisions=10)
    data = distill_labels.load_labels(tmp_path / "l")
    write_student(tmp_path / "s.json", {"FC": [0.5]})
    scores = label_cv.base_scores(data, tmp_path / "s.json")
    tail = FEATURE_NAMES.index("tail")
    fc, rc = data["crew_type"] == "FC", data["crew_type"] == "RC"
    # by hand: V' + 0.5 x tail for FC rows, V' alone for RC (no weights for that type)
    assert np.allclose(scores[fc], data["values"][fc] + 0.5 * data["features"][fc][..., tail])
    assert np.array_equal(scores[rc], data["values"][rc])
    folds = label_cv.seed_folds(data["seeds"], 4)
    same = label_cv.floor_gains(data, folds, lambda train: lambda test: np.nan_to_num(
        test["values"]), reference=np.asarray(data["values"]))
    assert set(same.values()) == {0.0}
    # against a base that already prefers long tails, a student gains less than against Eq. 9
    write_student(tmp_path / "good.json", {"FC": [3.0], "RC": [3.0]})
    good = label_cv.base_scores(data, tmp_path / "good.json")
    fit = lambda train: label_cv.linear_scorer(train, pooled=False)  # noqa: E731
    vs_eq9 = label_cv.summary(label_cv.floor_gains(data, folds, fit))["mean_s"]
    vs_good = label_cv.summary(label_cv.floor_gains(data, folds, fit, reference=good))["mean_s"]
    assert vs_eq9 < vs_good


def test_base_and_prior_options(tmp_path, capsys):
    write_labels(tmp_path / "l", floors=6, decisions=10)
    write_student(tmp_path / "s.json", {"FC": [1.0], "RC": [1.0]})
    out = tmp_path / "cv.json"
    assert label_cv.main([str(tmp_path / "l"), "--folds", "3", "--base",
                          str(tmp_path / "s.json"), "--prior", "--out", str(out)]) == 0
    report = json.loads(out.read_text())
    assert "s.json's pick" in report["against"] and "residual" in report["student"]
    write_student(tmp_path / "z.json", {})  # no weights: Eq. 9, so the same numbers as without
    assert label_cv.main([str(tmp_path / "l"), "--folds", "3", "--base",
                          str(tmp_path / "z.json"), "--out", str(tmp_path / "z.json.cv")]) == 0
    assert label_cv.main([str(tmp_path / "l"), "--folds", "3", "--out",
                          str(tmp_path / "eq9.cv")]) == 0
    z, eq9 = (json.loads((tmp_path / n).read_text()) for n in ("z.json.cv", "eq9.cv"))
    assert z["curve"] == eq9["curve"] and z["noisy_best"] == eq9["noisy_best"]
    # a base whose features the labels lack: a clear error naming the fix
    write_student(tmp_path / "b.json", {"FC": [1.0]}, features=("releases_h",))
    import pytest
    with pytest.raises(SystemExit):
        label_cv.main([str(tmp_path / "l"), "--prior"])
    assert label_cv.main([str(tmp_path / "l"), "--base", str(tmp_path / "b.json")]) == 2
    assert "relabel" in capsys.readouterr().err
