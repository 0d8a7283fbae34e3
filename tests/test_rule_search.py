"""The searched extension of Eq. 9 (training/search/rule.py): seeds, weights, fitness, resume."""

import json

import pytest
from test_ga import far_start_case

from agents.features import FEATURE_NAMES
from training.runs.runner import EpisodeRunner
from training.search.rule import (
    RuleSearchConfig,
    _rule_job,
    generation_seeds,
    paired_fitness,
    rule_weights,
    search_rule,
)


def test_each_generation_draws_its_seeds_from_the_pool_the_same_way_every_time():
    config = RuleSearchConfig(train_seeds=list(range(10)), seeds_per_generation=4,
                              select_seeds=[40])
    draws = [generation_seeds(config, g) for g in range(6)]
    assert all(len(d) == 4 == len(set(d)) and set(d) <= set(range(10)) for d in draws)
    assert draws == [generation_seeds(config, g) for g in range(6)]
    assert len({tuple(d) for d in draws}) > 1  # generations see different floors


def test_searched_weights_fill_the_other_features_with_zero():
    config = RuleSearchConfig(features=["tail", "successors"])
    weights = rule_weights(config, [0.25, -0.5], ["A", "B"])
    assert set(weights) == {"A", "B"} and weights["A"] == weights["B"]
    expected = [0.0] * len(FEATURE_NAMES)
    expected[FEATURE_NAMES.index("tail")], expected[FEATURE_NAMES.index("successors")] = .25, -.5
    assert weights["A"] == expected


def test_paired_fitness_by_hand():
    # limit 50 s: an unfinished floor counts 100 s. (100 - 90) + (100 - 80) over 2 = 15;
    # unfinished on both sides cancels: (100 - 100 + 70 - 80) / 2 = -5
    assert paired_fitness([100.0, None], [90.0, 80.0], 50.0) == 15.0
    assert paired_fitness([None, 70.0], [None, 80.0], 50.0) == -5.0


@pytest.mark.parametrize("settings, message", [
    ({"features": ["tail", "slack"]}, "each once"),
    ({"features": ["tail", "tail"]}, "each once"),
    ({"train_seeds": [0, 1], "seeds_per_generation": 3}, "exceeds the 2 train_seeds"),
    ({"train_seeds": [0, 1, 40], "seeds_per_generation": 2}, r"select_seeds \[40\]"),
])
def test_bad_settings_are_named_with_their_fix(settings, message):
    with pytest.raises(ValueError, match=message):
        RuleSearchConfig(**settings)


def test_zero_weights_play_eq9_and_a_nearness_weight_changes_the_order():
    # far_start_case: Eq. 9 cleans X-A first (two successors), the best order by hand (537 s
    # against 655 s when X-B, beside the crew, goes first: tests/test_ga.py)
    runner = EpisodeRunner(far_start_case())
    config = RuleSearchConfig(features=["nearness"], train_seeds=[0], seeds_per_generation=1,
                              select_seeds=[1])
    heuristic = _rule_job(runner, None, 5, 0, "scripted")["makespan_s"]
    zero = _rule_job(runner, rule_weights(config, [0.0], ["XC", "KC", "MC"]), 5, 0,
                     "scripted")["makespan_s"]
    near = _rule_job(runner, rule_weights(config, [2.0], ["XC", "KC", "MC"]), 5, 0,
                     "scripted")["makespan_s"]
    assert zero == heuristic
    assert near > heuristic


def test_a_resumed_search_continues_exactly_and_checks_on_unseen_seeds(tmp_path):
    case = far_start_case()
    settings = dict(features=["nearness", "tail"], popsize=3, train_seeds=[0, 1],
                    seeds_per_generation=1, select_seeds=[5, 6], seed=2)
    whole = search_rule(case, RuleSearchConfig(generations=2, **settings), tmp_path / "a",
                        progress=False)
    search_rule(case, RuleSearchConfig(generations=1, **settings), tmp_path / "b",
                progress=False)
    with pytest.raises(ValueError, match="other settings"):
        search_rule(case, RuleSearchConfig(generations=2, **{**settings, "seed": 3}),
                    tmp_path / "b", resume=True, progress=False)
    resumed = search_rule(case, RuleSearchConfig(generations=2, **settings), tmp_path / "b",
                          resume=True, progress=False)
    def strip(log):  # the stopped run's own selection check adds to its episode count
        return [{k: v for k, v in row.items() if k != "episodes"} for row in log]

    assert strip(resumed.log) == strip(whole.log) and resumed.selection == whole.selection
    assert (tmp_path / "a" / "rule.json").read_text() == (tmp_path / "b" / "rule.json").read_text()
    rule = json.loads((tmp_path / "a" / "rule.json").read_text())
    assert rule["kind"] == "cmdp-student" and set(rule["selection"]["checked"]) == {"1", "2"}
    # Eq. 9 on 4 seeds, 2 generations x 3 candidates x 1 seed, 2 means x 2 selection seeds
    assert whole.evaluations == 4 + 2 * 3 * 1 + 2 * 2
    chosen = rule["selection"]["generation"]
    if chosen:  # the kept mean beat Eq. 9 on the selection seeds, and its weights are written
        assert rule["selection"]["diff_mean_s"] < 0
        assert rule["searched"] == pytest.approx(dict(zip(
            ["nearness", "tail"], whole.log[chosen - 1]["mean_x"], strict=True)), abs=1e-6)
    else:  # none did: the rule is Eq. 9
        assert all(v == 0 for v in rule["searched"].values())


def test_the_kept_mean_is_the_best_checked_or_eq9():
    from training.search.rule import SearchState, choose, generations_checked

    config = RuleSearchConfig(features=["tail"], generations=3, select_every=2,
                              train_seeds=[0, 1], seeds_per_generation=1, select_seeds=[5])
    log = [{"generation": g, "mean_x": [0.1 * g]} for g in (1, 2, 3)]
    state = SearchState(3, None, log=log)
    state.checked = {2: {"diff_mean_s": -50.0}, 3: {"diff_mean_s": -80.0}}
    assert generations_checked(config) == [2, 3]  # every 2nd, and the last
    assert choose(state, config)["generation"] == 3
    assert choose(state, config)["weights"] == [pytest.approx(0.3)]
    state.checked = {2: {"diff_mean_s": 10.0}, 3: {"diff_mean_s": 0.0}}
    picked = choose(state, config)
    assert picked["generation"] == 0 and picked["weights"] == [0.0]


def test_cmdp_search_rule_names_a_bad_setting_and_writes_a_usable_rule(tmp_path, capsys):
    from agents.specs import evaluator_from_spec
    from training.commands import search_rule as cli

    assert cli.main(["--set", "seeds_per_generation=0", "--out", str(tmp_path / "bad")]) == 2
    assert "seeds_per_generation = 0 must be positive" in capsys.readouterr().err
    tiny = str(__import__("cmdp_pymunk").TINY_CASE)
    out = tmp_path / "run"
    assert cli.main(["--set", f"case='{tiny}'", "--set", "generations=1", "--set", "popsize=2",
                     "--set", "train_seeds=[0, 1]", "--set", "seeds_per_generation=1",
                     "--set", "select_seeds=[2]", "--workers", "1", "--out", str(out),
                     "--no-progress"]) == 0
    assert "means checked on selection seeds 2..2" in capsys.readouterr().out
    for name in ("rule.json", "history.csv", "checkpoint.pkl", "config.json"):
        assert (out / name).is_file(), name
    assert evaluator_from_spec(f"student:{out / 'rule.json'}").candidates == 5


def test_a_search_on_the_event_floor_is_selected_on_the_pymunk_floor(tmp_path):
    """Generations on the event floor with a binding feature, the selection on the pymunk
    floor: each seed's Eq. 9 baseline comes from the floor its seed runs on, and the rule
    file names its features and floors."""
    case = far_start_case()
    config = RuleSearchConfig(features=["nearness", "unlocks_binding"], popsize=3,
                              train_seeds=[0, 1], seeds_per_generation=1, select_seeds=[5],
                              generations=1, fidelity="event")
    state = search_rule(case, config, tmp_path, progress=False)
    on = {f: EpisodeRunner(case, fidelity=f) for f in ("event", "pymunk")}
    assert state.baseline[0] == on["event"].run("priority", "scripted", 0)["makespan_s"]
    assert state.baseline[5] == on["pymunk"].run("priority", "scripted", 5)["makespan_s"]
    rule = json.loads((tmp_path / "rule.json").read_text())
    assert (rule["fidelity"], rule["select_fidelity"]) == ("event", "pymunk")
    assert "unlocks_binding" in rule["features"] and len(rule["features"]) > len(FEATURE_NAMES)
    with pytest.raises(ValueError, match="each once, from"):
        RuleSearchConfig(features=["crane_queue"])


def _student(tmp_path, weights, candidates=3):
    from agents.student import StudentEvaluator

    path = tmp_path / "student.json"
    StudentEvaluator(weights, candidates, FEATURE_NAMES).save(path, {})
    return str(path)


def test_a_search_from_a_student_offsets_its_weights_per_crew_type_by_hand(tmp_path):
    """``start``: the search vector is an offset on the start student's weights; with
    ``per_type`` one block per crew type the student holds weights for (in sorted order),
    a type without weights keeps none."""
    n = len(FEATURE_NAMES)
    a, b = [0.1 * k for k in range(n)], [-0.2] * n
    start = _student(tmp_path, {"B": b, "A": a})
    i, j = FEATURE_NAMES.index("nearness"), FEATURE_NAMES.index("rank1")
    pooled = RuleSearchConfig(features=["nearness", "rank1"], start=start, candidates=3)
    weights = rule_weights(pooled, [1.0, -1.0], ["A", "B", "C"])
    assert weights["A"][i] == pytest.approx(a[i] + 1) and weights["B"][j] == pytest.approx(-1.2)
    assert weights["C"][i] == 1.0 and weights["C"][j] == -1.0  # zeros plus the offset
    typed = RuleSearchConfig(features=["nearness", "rank1"], start=start, candidates=3,
                             per_type=True)
    from training.search.rule import search_dimension, search_names

    assert search_names(typed, ["C", "B", "A"]) == ["A.nearness", "A.rank1", "B.nearness",
                                                    "B.rank1"]
    assert search_dimension(typed, ["A", "B", "C"]) == 4
    weights = rule_weights(typed, [1.0, 2.0, 3.0, 4.0], ["A", "B", "C"])
    assert weights["A"][i] == pytest.approx(a[i] + 1) and weights["A"][j] == pytest.approx(
        a[j] + 2)
    assert weights["B"][i] == pytest.approx(2.8) and weights["B"][j] == pytest.approx(3.8)
    assert weights["C"] == [0.0] * n
    others = [k for k in range(n) if k not in (i, j)]
    assert [weights["A"][k] for k in others] == pytest.approx([a[k] for k in others])
    with pytest.raises(ValueError, match="expected 4"):
        rule_weights(typed, [1.0, 2.0], ["A", "B"])


@pytest.mark.parametrize("settings, message", [
    ({"per_type": True}, "give start"),
    ({"start": "STUDENT", "features": ["nearness", "unlocks_binding"]},
     r"\['unlocks_binding'\] are not the start student's"),
    ({"start": "STUDENT", "features": ["nearness"], "candidates": 5}, "fix: candidates = 3"),
])
def test_bad_start_settings_are_named_with_their_fix(tmp_path, settings, message):
    settings = {k: (_student(tmp_path, {}) if v == "STUDENT" else v)
                for k, v in settings.items()}
    with pytest.raises(ValueError, match=message):
        RuleSearchConfig(**settings)


def test_a_search_from_a_student_checks_the_student_and_keeps_it_unless_beaten(tmp_path):
    from training.search.rule import SearchState, choose, generations_checked

    start = _student(tmp_path, {"A": [0.0] * len(FEATURE_NAMES)})
    config = RuleSearchConfig(features=["nearness"], generations=2, select_every=2,
                              train_seeds=[0, 1], seeds_per_generation=1, select_seeds=[5],
                              start=start, candidates=3)
    assert generations_checked(config) == [0, 2]
    state = SearchState(2, None, log=[{"generation": g, "mean_x": [0.5 * g]} for g in (1, 2)])
    state.checked = {0: {"diff_mean_s": -90.0}, 2: {"diff_mean_s": -50.0}}
    kept = choose(state, config)
    assert kept["generation"] == 0 and kept["weights"] == [0.0] and "note" not in kept
    state.checked = {0: {"diff_mean_s": -90.0}, 2: {"diff_mean_s": -120.0}}
    assert choose(state, config)["weights"] == [1.0]
    # a whole (tiny) search: generation 0 is played on the selection seeds too
    case = far_start_case()
    run = RuleSearchConfig(features=["nearness"], popsize=2, train_seeds=[0, 1],
                           seeds_per_generation=1, select_seeds=[5], generations=1,
                           start=start, candidates=3)
    state = search_rule(case, run, tmp_path / "run", progress=False)
    assert set(state.checked) == {0, 1}
    assert json.loads((tmp_path / "run" / "rule.json").read_text())["start"] == start
