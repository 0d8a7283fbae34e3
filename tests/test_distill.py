"""The student (agents.student) and its distillation (training.research.distill): plumbing and
by-hand numbers, not learning."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import event_floor, play_floor

import cmdp_pymunk
from agents.features import FEATURE_NAMES, FloorFacts
from agents.student import StudentEvaluator
from training.research import distill, distill_fit, distill_labels, distill_model


def test_a_student_without_weights_is_eq_9_exactly(priority_floor):
    zero = {t: [0.0] * len(FEATURE_NAMES) for t in ("JCC", "HIC", "GC", "RC", "FC")}
    student, base = event_floor(StudentEvaluator(zero)), priority_floor
    assert student.log.events == base.log.events


def test_a_student_with_weights_changes_choices_and_holds_them(priority_floor):
    # a large weight against nearness (far targets first) overrides Eq. 9 on the floor
    w = [0.0] * len(FEATURE_NAMES)
    w[FEATURE_NAMES.index("nearness")] = -5.0
    floor = event_floor(StudentEvaluator({t: w for t in ("RC", "FC")}))
    assert floor.site.done and floor.log.events != priority_floor.log.events


def test_floor_facts_tail_by_hand(tiny_case):
    # tiny case: X-A (2 min) -> K-A (1 min + 30 s crane) -> M-C (0.3 m3 at 0.1 m3/min = 3 min)
    env = cmdp_pymunk.parallel_env(case=tiny_case, seed=0)
    env.reset(seed=0)
    facts = FloorFacts.of(env.engine.site)
    assert facts.tail_s.tolist() == pytest.approx([120 + 90 + 180, 90 + 180, 120, 180])
    # the bottleneck: X crews have 240 s for one crew, M 180 s for two crews, K 90 s
    assert facts.bottleneck == "XC"
    assert facts.unlock_s.tolist() == [0.0, 0.0, 0.0, 0.0]


# what ``training.research.distill`` held before it was split (issue 43); older scripts and the
# docs import these from it
BEFORE_THE_SPLIT = {
    "distill_labels": ("lookahead_settings", "futures_option", "teacher_options",
                       "features_option", "label_teacher", "label_floor", "decision_state",
                       "save_labels", "_label_job", "label_files", "load_labels"),
    "distill_fit": ("FIT_DEFAULTS", "soft_targets", "choice_weights", "FIT_WEIGHTS",
                    "fit_weights", "select_features"),
    "distill_model": ("MODEL_FIT_DEFAULTS", "MODEL_FIT_HELP", "choice_rows", "choice_venv",
                      "new_choice_model", "choice_agreement", "choice_regret_s",
                      "fit_choice_model", "save_model"),
}


def test_the_split_modules_names_are_still_distills():
    homes = {"distill_labels": distill_labels, "distill_fit": distill_fit,
             "distill_model": distill_model}
    for home, names in BEFORE_THE_SPLIT.items():
        for name in names:
            assert getattr(distill, name) is getattr(homes[home], name), name
            assert name.startswith("_") or name in distill.__all__, name
    assert all(hasattr(distill, name) for name in distill.__all__)


def test_soft_targets_by_hand():
    # makespans 100, 400 and a missing candidate, tau 300: e^0 : e^-1 : 0
    p = distill_fit.soft_targets(np.array([[100.0, 400.0, np.nan]]), 300.0)
    assert p[0].tolist() == pytest.approx([1 / (1 + np.e ** -1), np.e ** -1 / (1 + np.e ** -1),
                                           0.0])


def test_fit_finds_a_feature_the_teacher_follows():
    rng = np.random.default_rng(0)
    n, k, f = 300, 3, len(FEATURE_NAMES)
    values = np.sort(rng.random((n, k)), axis=1)[:, ::-1]  # Eq. 9 ranks candidate 0 first
    features = rng.random((n, k, f))
    tail = FEATURE_NAMES.index("tail")
    makespan = 30000.0 - 2000.0 * features[:, :, tail]  # the longest tail finishes sooner
    data = {"crew_type": np.array(["FC"] * n), "values": values, "features": features,
            "makespan_s": makespan}
    weights, report = distill_fit.fit_weights(data, tau_s=300.0, l2=0.01)
    assert weights["FC"][tail] > 0.5
    assert report["FC"]["agree_student_teacher"] > report["FC"]["agree_base_teacher"] + 0.3


def test_label_fit_and_simulate_on_the_tiny_case(tmp_path):
    from training.commands import simulate

    labels, model = tmp_path / "labels", tmp_path / "new" / "student.json"
    tiny = str(cmdp_pymunk.TINY_CASE)
    assert distill.main(["label", "--case", tiny, "--seeds", "0-2", "--candidates", "2",
                         "--out", str(labels)]) == 0
    assert sorted(p.name for p in labels.iterdir()) == ["seed-0.npz", "seed-1.npz",
                                                        "seed-2.npz"]
    assert distill.main(["label", "--case", tiny, "--seeds", "0-2", "--out",
                         str(labels)]) == 0  # resumes: nothing left to do
    assert distill.main(["fit", str(labels), "--out", str(model)]) == 0
    data = json.loads(model.read_text())
    assert data["label_seeds"] == [0, 1, 2] and data["command"].startswith("python -m")
    # the same decisions split over two folders (rounds of policy iteration): the same weights
    part = tmp_path / "part"
    part.mkdir()
    (labels / "seed-2.npz").rename(part / "seed-2.npz")
    both = tmp_path / "both.json"
    assert distill.main(["fit", str(labels), str(part), "--out", str(both)]) == 0
    fitted = json.loads(both.read_text())
    assert fitted["label_seeds"] == [0, 1, 2] and fitted["weights"] == data["weights"]
    (part / "seed-2.npz").rename(labels / "seed-2.npz")
    assert simulate.main(["--case", tiny, "--evaluator", f"student:{model}", "--out",
                          str(tmp_path / "run"), "--no-charts", "--no-progress"]) == 0


def test_a_bad_student_file_says_what_to_do(tmp_path):
    bad = tmp_path / "x.json"
    bad.write_text('{"kind": "other"}')
    with pytest.raises(ValueError, match="refit it with training.research.distill"):
        StudentEvaluator.load(bad)
    with pytest.raises(ValueError, match="cannot read it"):
        StudentEvaluator.load(tmp_path / "missing.json")
    with pytest.raises(ValueError, match="expected 11"):
        StudentEvaluator({"FC": [1.0, 2.0]})
    assert distill.main(["fit", str(tmp_path)]) == 2


def test_choice_rows_pad_clip_and_mask_by_hand():
    # two decisions of a 2-candidate label set, shown to a policy of 3 rows: V' stays (inside
    # [-1, 1.5]), a feature of 1.7 is clipped to 1, a missing candidate and the pad are zeros
    f = len(FEATURE_NAMES)
    values = np.array([[1.2, 0.4], [0.9, np.nan]])
    features = np.zeros((2, 2, f))
    features[0, 1, 0] = 1.7
    features[1, 1, 0] = 0.5  # behind a NaN value: not a candidate
    flat, mask = distill_model.choice_rows({"values": values, "features": features}, cap=3)
    rows = flat.reshape(2, 3, f + 1)
    assert mask.tolist() == [[True, True, False], [True, False, False]]
    assert rows[0, :, 0].tolist() == pytest.approx([1.2, 0.4, 0.0])
    assert rows[0, 1, 1] == 1.0 and rows[1, 1].tolist() == [0.0] * (f + 1)
    with pytest.raises(ValueError, match="--candidates 2"):
        distill_model.choice_rows({"values": values, "features": features}, cap=1)
    # labels with every feature (policy iteration's): the model's columns taken by name, the
    # same rows; labels without one of them are refused with the fix
    from agents.features import ALL_FEATURES

    wide = np.zeros((2, 2, len(ALL_FEATURES)))
    wide[..., [ALL_FEATURES.index(n) for n in FEATURE_NAMES]] = features
    wide[..., len(FEATURE_NAMES):] = 9.0  # the binding features: not the model's
    same, _ = distill_model.choice_rows({"values": values, "features": wide,
                                   "feature_names": ALL_FEATURES}, cap=3)
    assert same.tolist() == flat.tolist()
    with pytest.raises(ValueError, match="areas_near missing"):
        distill_model.choice_rows({"values": values, "features": features[..., :4],
                             "feature_names": FEATURE_NAMES[:3] + ("rank1",)}, cap=3)


def test_fit_model_learns_a_feature_the_teacher_follows_and_loads_as_an_evaluator(tmp_path):
    from agents.candidates import CandidateModelEvaluator

    rng = np.random.default_rng(1)
    n, k, f = 400, 3, len(FEATURE_NAMES)
    values = np.sort(rng.random((n, k)), axis=1)[:, ::-1] * 0.2  # Eq. 9 ranks candidate 0
    features = rng.random((n, k, f))
    tail = FEATURE_NAMES.index("tail")
    data = {"values": values, "features": features,
            "makespan_s": 30000.0 - 2000.0 * features[:, :, tail],
            "row_seed": np.repeat(np.arange(10), n // 10)}
    # 100 epochs: agreement 0.938 against Eq. 9's 0.25 on validation (200 gave 0.975), far
    # past the 0.3 margin asked, at half the fit's seconds (issue 43: the gate's time)
    model, report = distill_model.fit_choice_model(data, cap=3, settings={"epochs": 100},
                                             log=lambda *_: None)
    assert report["validation_seeds"] == [8, 9]
    assert report["agree_start_teacher_validation"] == report["agree_eq9_teacher_validation"]
    assert report["agree_model_teacher_validation"] > \
        report["agree_eq9_teacher_validation"] + 0.3
    assert report["validation_loss"] < report["validation_loss_start"]
    assert report["regret_model_validation_s"] < report["regret_eq9_validation_s"]

    model.save(tmp_path / "m.zip")
    evaluator = CandidateModelEvaluator(tmp_path / "m.zip")
    assert evaluator.view.cap == 3


def test_choice_regret_by_hand():
    # the teacher's makespans 100 / 400 / missing and 250 / 50 / 75: picking row 1 both times
    # loses 300 s, then 0 s (mean 150); a masked row is never picked
    makespan = np.array([[100.0, 400.0, np.nan], [250.0, 50.0, 75.0]])
    mask = ~np.isnan(makespan)
    scores = np.array([[0.0, 1.0, 9.0], [0.0, 1.0, 0.5]])
    assert distill_model.choice_regret_s(scores, mask, makespan) == pytest.approx(150.0)


def test_label_with_expected_paces_and_an_acting_policy_then_fit_model(tmp_path):
    from training.commands import simulate

    labels, model = tmp_path / "labels", tmp_path / "m" / "model.zip"
    tiny = str(cmdp_pymunk.TINY_CASE)
    assert distill.main(["label", "--case", tiny, "--seeds", "0-1", "--candidates", "2",
                         "--futures", "expected", "--out", str(labels)]) == 0
    assert distill.main(["label", "--case", tiny, "--seeds", "2", "--candidates", "2",
                         "--futures", "expected", "--acting", "nearest",
                         "--out", str(labels)]) == 0
    data = distill_labels.load_labels(labels)
    assert data["teachers"] == ["lookahead:candidates=2+futures=expected"] * 3
    assert data["acting"] == ["", "", "nearest"]
    assert distill.main(["fit-model", str(labels), "--out", str(model)]) == 0
    meta = json.loads(model.with_suffix(".distill.json").read_text())
    assert meta["label_seeds"] == [0, 1, 2] and meta["fit"]["validation_seeds"] == [2]
    assert simulate.main(["--case", tiny, "--evaluator", str(model), "--out",
                          str(tmp_path / "run"), "--no-charts", "--no-progress"]) == 0


def test_bad_label_options_fail_before_any_floor(tmp_path, capsys):
    assert distill.main(["label", "--futures", "many", "--out", str(tmp_path / "a")]) == 2
    assert "--futures 'many'" in capsys.readouterr().err
    assert distill.main(["label", "--acting", "student:missing.json",
                         "--out", str(tmp_path / "b")]) == 2
    assert "missing.json" in capsys.readouterr().err
    assert distill.main(["label", "--case", str(tmp_path / "missing.toml"),
                         "--out", str(tmp_path / "c")]) == 2
    assert "missing.toml" in capsys.readouterr().err
    assert not any((tmp_path / d).exists() for d in ("a", "b", "c"))


def test_label_states_give_back_each_decisions_floor(tmp_path):
    from agents.features import FloorFacts, candidate_features
    from cmdp_pymunk.evaluate import PriorityEvaluator
    from cmdp_pymunk.streams import EXPECTED
    from training.research import label_noise

    tiny = str(cmdp_pymunk.TINY_CASE)
    plain, kept = tmp_path / "plain", tmp_path / "kept"
    for out, extra in ((plain, []), (kept, ["--states"])):
        assert distill.main(["label", "--case", tiny, "--seeds", "0-1", "--candidates", "2",
                             "--futures", "expected", "--out", str(out), *extra]) == 0
    assert not list(plain.glob("*.states.pkl"))
    for seed in (0, 1):
        a, b = np.load(plain / f"seed-{seed}.npz"), np.load(kept / f"seed-{seed}.npz")
        # keeping the states does not change the floor or its labels
        for key in ("choice", "makespan_s", "features", "values", "floor_makespan_s"):
            assert np.array_equal(a[key], b[key], equal_nan=True), key
        states = label_noise.load_states(kept / f"seed-{seed}.states.pkl")
        assert len(states) == len(b["choice"]) >= 1
        engine, low_level, i, candidates = states[0]
        # the teacher's low level comes with it, its plans in the kept floor's memory (a fresh
        # scripted navigator can walk a branch differently: 1 of 67 on the built-in case, by
        # 1,107 s)
        assert type(low_level).__name__ == "Navigator"
        assert engine.memory["navigator"].engine is engine
        site = engine.site
        crew = site.crews[i]
        priorities = PriorityEvaluator().priorities(crew, site, engine.positions[i])
        phi = candidate_features(FloorFacts.of(site), crew, site, engine.positions[i],
                                 candidates, priorities, engine.positions)
        assert np.allclose(phi, b["features"][0, :len(candidates)])
        assert [priorities[t] for t in candidates] == list(b["values"][0, :len(candidates)])
        # a branch from the kept floor is the teacher's own: the same makespan per candidate
        for k in range(len(candidates)):
            assert label_noise.candidate_makespan(str(kept / f"seed-{seed}.states.pkl"), 0, k,
                                                  EXPECTED) == b["makespan_s"][0, k]


# -- typed models: the student as a masked-choice model -----------------------------------------

def schedule(evaluator, case, seed: int = 0):
    """A floor's schedule: its makespan and each task's start times, and its whole event log."""
    env = play_floor(evaluator, case, seed)
    starts = {}
    for e in env.log.events:
        if e.kind == "task_start":
            starts.setdefault(e.subject, []).append(e.time_s)
    return (env.engine.makespan_s, starts), env.log.events


def test_student_model_plays_the_students_schedule_on_the_tiny_case(tmp_path, capsys):
    from agents.candidates import CREW_TYPES
    from agents.features import ALL_FEATURES
    from agents.specs import evaluator_from_spec

    tiny = str(cmdp_pymunk.TINY_CASE)
    labels, student = tmp_path / "labels", tmp_path / "student.json"
    # labels of every feature, as policy iteration's; the student fitted on the model's 11
    assert distill.main(["label", "--case", tiny, "--seeds", "0-2", "--candidates", "2",
                         "--features", "all", "--out", str(labels)]) == 0
    assert distill_labels.load_labels(labels)["feature_names"] == ALL_FEATURES
    assert distill.main(["fit", str(labels), "--features", "first", "--out",
                         str(student)]) == 0
    fitted = json.loads(student.read_text())
    assert fitted["features"] == list(FEATURE_NAMES) and fitted["candidates"] == 2
    assert distill.main(["fit", str(labels), "--features", "tail,nope", "--out",
                         str(tmp_path / "x.json")]) == 2
    assert "nope unknown" in capsys.readouterr().err
    # fit-model --typed on the same labels: typed rows from their crew_type, the hold saved
    fitted_model = tmp_path / "fitted" / "typed.zip"
    assert distill.main(["fit-model", str(labels), "--typed", "--hold-choice", "--out",
                         str(fitted_model)]) == 0
    meta = json.loads(fitted_model.with_suffix(".distill.json").read_text())
    assert meta["typed"] and meta["hold_choice"]
    assert evaluator_from_spec(str(fitted_model)).view.types == CREW_TYPES
    # three decisions (one a floor) teach it almost nothing (weights about 1e-6): a hand-made
    # student of the same file that sends crews to the farther target changes the schedule
    hand = tmp_path / "hand.json"
    far = [0.0] * len(FEATURE_NAMES)
    far[FEATURE_NAMES.index("nearness")] = -5.0
    hand.write_text(json.dumps({**fitted, "weights": {"RC": far, "HIC": far}}))
    case = cmdp_pymunk.load_case(tiny)
    eq9, _ = schedule("priority", case)
    for made in (student, hand):
        model = made.with_suffix(".zip")
        assert distill.main(["student-model", str(made), "--out", str(model),
                             "--hold-choice"]) == 0
        meta = json.loads(model.with_suffix(".distill.json").read_text())
        assert meta["student"] == str(made) and meta["command"].startswith("python -m")
        assert meta["hold_choice"] and meta["student_meta"]["features"] == fitted["features"]
        evaluator = evaluator_from_spec(str(model))
        assert evaluator.view.types == CREW_TYPES and evaluator.view.cap == 2
        for seed in (0, 1):
            students, student_events = schedule(StudentEvaluator.load(made), case, seed)
            models, model_events = schedule(evaluator_from_spec(str(model)), case, seed)
            assert models == students and model_events == student_events
    assert schedule(StudentEvaluator.load(hand), case)[0] != eq9


def test_typed_choice_rows_by_hand():
    # a 2-candidate decision of an RC crew and one of a crew type outside the vocabulary,
    # shown to a policy of 3 rows: RC's one-hot on its real rows; zeros for the other crew
    # and on padded rows; the untyped columns as before
    from agents.candidates import CREW_TYPES

    f = len(FEATURE_NAMES)
    data = {"values": np.array([[1.2, 0.4], [0.9, 0.1]]), "features": np.full((2, 2, f), 0.5),
            "crew_type": np.array(["RC", "XC"])}
    flat, mask = distill_model.choice_rows(data, cap=3, types=CREW_TYPES)
    rows = flat.reshape(2, 3, f + 1 + len(CREW_TYPES))
    assert rows[0, :2, f + 1:].tolist() == [[0.0, 0.0, 0.0, 1.0, 0.0]] * 2
    assert (rows[1, :, f + 1:] == 0).all() and (rows[:, 2] == 0).all()
    plain, same_mask = distill_model.choice_rows(data, cap=3)
    assert (rows[..., :f + 1].reshape(2, -1) == plain).all() and (mask == same_mask).all()
    with pytest.raises(ValueError, match="crew_type"):
        distill_model.choice_rows({k: data[k] for k in ("values", "features")}, 3, CREW_TYPES)


def test_typed_fit_model_learns_per_type_choices(tmp_path):
    # JCC's teacher wants the longest tail, HIC's the shortest: one shared weight vector
    # cannot follow both, a typed model can
    rng = np.random.default_rng(2)
    n, k, f = 400, 3, len(FEATURE_NAMES)
    tail = FEATURE_NAMES.index("tail")
    features = rng.random((n, k, f))
    crew_type = np.array(["JCC", "HIC"] * (n // 2))
    sign = np.where(crew_type == "JCC", 1.0, -1.0)[:, None]
    data = {"values": np.sort(rng.random((n, k)), axis=1)[:, ::-1] * 0.2, "features": features,
            "makespan_s": 30000.0 - 2000.0 * sign * features[:, :, tail],
            "row_seed": np.repeat(np.arange(10), n // 10), "crew_type": crew_type}
    settings = {"epochs": 200}
    typed, report = distill_model.fit_choice_model(data, 3, settings=settings, log=lambda *_: None,
                                             typed=True, hold_choice=True)
    _, plain = distill_model.fit_choice_model(data, 3, settings=settings, log=lambda *_: None)
    assert report["agree_model_teacher_validation"] > 0.8
    assert report["agree_model_teacher_validation"] > plain["agree_model_teacher_validation"] + 0.2
    assert typed.policy.hold_choice and typed.policy.types[:2] == ("JCC", "HIC")


def test_relabel_replays_the_acting_floor_and_adds_features(tmp_path, capsys):
    """``distill relabel`` computes other features for labels without the teacher: the
    replayed floor of the acting policy meets every decision of the file (same candidates,
    Eq. 9 values and shared features), the teacher's makespans and choices are kept; a floor
    the lookahead drove itself, or a file whose decisions are not the replay's, is refused."""
    from agents.features import ALL_FEATURES, FEATURE_NAMES

    tiny = str(cmdp_pymunk.TINY_CASE)
    labels, wide = tmp_path / "labels", tmp_path / "wide"
    assert distill.main(["label", "--case", tiny, "--seeds", "0-1", "--candidates", "2",
                         "--futures", "expected", "--acting", "nearest",
                         "--out", str(labels)]) == 0
    assert distill.main(["relabel", str(labels), "--case", tiny, "--out", str(wide)]) == 0
    old, new = distill_labels.load_labels(labels), distill_labels.load_labels(wide)
    assert len(old["choice"]) > 0 and new["feature_names"] == ALL_FEATURES
    for key in ("crew_type", "choice", "row_seed"):
        assert np.array_equal(old[key], new[key])
    for key in ("values", "makespan_s"):
        assert np.array_equal(old[key], new[key], equal_nan=True)
    assert np.allclose(new["features"][..., :len(FEATURE_NAMES)], old["features"])
    assert new["acting"] == old["acting"] == ["nearest", "nearest"]
    # an endgame teacher (from=SHARE; the tiny floor's one decision of seed 0 comes before
    # 90 % of its tasks end): the replay skips what the teacher skipped
    late, late_wide = tmp_path / "late", tmp_path / "late_wide"
    assert distill.main(["label", "--case", tiny, "--seeds", "0", "--acting", "nearest",
                         "--teacher", "candidates=2+futures=expected+from=0.9",
                         "--out", str(late)]) == 0
    assert np.sum(old["row_seed"] == 0) > 0 == len(np.load(late / "seed-0.npz")["choice"])
    assert distill.main(["relabel", str(late), "--case", tiny, "--out", str(late_wide)]) == 0
    assert len(np.load(late_wide / "seed-0.npz")["choice"]) == 0
    # a label file of the lookahead's own floor: nothing to replay without it
    own = tmp_path / "own"
    assert distill.main(["label", "--case", tiny, "--seeds", "0", "--candidates", "2",
                         "--futures", "expected", "--out", str(own)]) == 0
    assert distill.main(["relabel", str(own), "--case", tiny,
                         "--out", str(tmp_path / "x")]) == 2
    assert "followed the lookahead itself" in capsys.readouterr().err
    # a file whose decisions are not the replayed floor's (here: another Eq. 9 value)
    tampered = tmp_path / "tampered"
    tampered.mkdir()
    data = dict(np.load(labels / "seed-0.npz"))
    data["values"] = data["values"] + 0.01
    np.savez(tampered / "seed-0.npz", **data)
    assert distill.main(["relabel", str(tampered), "--case", tiny,
                         "--out", str(tmp_path / "y")]) == 2
    assert "decision 0" in capsys.readouterr().err
    assert not (tmp_path / "y" / "seed-0.npz").exists()
