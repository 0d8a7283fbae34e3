"""``cmdp-plan`` (training/search/plan_search.py): the search space, the pruner's rungs, the
Pareto front by hand, and whole searches on the tiny case's event floor that find a planted best
plan, resume without playing a floor twice, and refuse bad settings before anything runs."""

import json
import tomllib

import pytest

from cmdp_pymunk import TINY_CASE, load_case
from cmdp_pymunk.cases.load import case_from_dict
from media.pareto import pareto_front
from training.commands import plan
from training.search.plan_search import (
    PlanConfig,
    cost_bound,
    plan_changes,
    search_space,
    study_storage,
)

optuna = pytest.importorskip("optuna")


def planted_case(tmp_path):
    """The tiny case with HIC and RC crew levers (1-2 each), RC crews free and HIC crews
    dear: one more RC crew takes the tiny floor to about 0.7 x its makespan (its one joint is
    shared), one more HIC crew saves nothing (measured: -2 s) and costs 5,000/h, so the
    cheapest plan is RC=2 with one HIC crew."""
    data = load_case(TINY_CASE).model_dump(mode="json")
    data["levers"] = {"crews": {"HIC": {"min": 1, "max": 2}, "RC": {"min": 1, "max": 2}}}
    data["cost"] = {"crew_rate_per_h": {"RC": 0.0, "HIC": 5000.0}}
    case = case_from_dict(data, "planted")
    path = tmp_path / "planted.toml"
    from cmdp_pymunk.cases.levers import variant_toml

    path.write_text(variant_toml(case), encoding="utf-8")
    return path


def test_search_space_without_levers_is_one_crew_either_way_and_reorder_points():
    case = load_case(None)  # the built-in floor: no [levers]
    space = {lv.key: lv for lv in search_space(case)}
    # RC and FC have 2 crews: 1..3; JCC, HIC, GC have 1: 1..2
    assert (space["crews.RC"].low, space["crews.RC"].high, space["crews.RC"].base) == (1, 3, 2)
    assert (space["crews.JCC"].low, space["crews.JCC"].high) == (1, 2)
    # rebars' storage holds 3.0: its reorder point from 0 to 1.5 in 4 steps of 0.375
    rebars = space["rebars.reorder_at"]
    assert (rebars.low, rebars.high, rebars.step) == (0.0, 1.5, 0.375)
    changes = plan_changes(list(space.values()), {k: lv.base for k, lv in space.items()}
                           | {"crews.RC": 3.0, "rebars.reorder_at": 0.75})
    assert [c.label for c in changes] == ["RC=3", "rebars.reorder_at=0.75"]


def test_rungs_double_up_to_every_search_seed():
    assert PlanConfig(search_seeds=tuple(range(16)), min_seeds=2).rungs() == [2, 4, 8, 16]
    assert PlanConfig(search_seeds=tuple(range(10)), min_seeds=4).rungs() == [4, 8, 10]
    assert PlanConfig(objective="pareto", search_seeds=tuple(range(10))).rungs() == [10]


def test_pareto_front_by_hand():
    # (3, 1) and (1, 3) and (2, 2) are the front; (2, 3) is beaten by (2, 2), (4, 4) by all
    points = [(2, 3), (3, 1), (1, 3), (4, 4), (2, 2)]
    assert pareto_front(points) == [2, 4, 1]


ARGS = ["--trials", "8", "--search-seeds", "0-5", "--confirm-seeds", "100-105", "--confirm",
        "2", "--min-seeds", "2", "--workers", "1", "--no-progress", "--confirm-fidelity",
        "event"]


def test_a_search_finds_the_planted_cheapest_plan_and_writes_its_outputs(tmp_path, capsys):
    case_path = planted_case(tmp_path)
    out = tmp_path / "plan"
    assert plan.main(["--case", str(case_path), "--objective", "cost", "--out", str(out),
                      *ARGS]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["chosen"]["plan"] == "RC=2"
    assert summary["chosen"]["crews"] == "HIC 1, RC 2"
    held = summary["chosen"]["held_out"]
    assert held["cost_diff_mean"] < 0 and held["makespan_diff_mean_s"] < 0
    # the plans tried are counted; search and confirmation seeds are disjoint
    assert summary["tried"]["trials"] == 8
    assert not set(summary["search"]["seeds"]) & set(summary["confirmation"]["seeds"])
    # plan.toml reads back as the chosen case
    chosen = load_case(out / "plan.toml")
    assert sum(c.type == "RC" for c in chosen.crews) == 2
    assert sum(c.type == "HIC" for c in chosen.crews) == 1
    assert (out / "media" / "pareto.png").stat().st_size > 1000
    csv = (out / "levers.csv").read_text().splitlines()
    assert csv[0].startswith("lever,") and csv[1].startswith("as the case,")
    assert "cmdp-plan: chosen: RC=2" in capsys.readouterr().out
    # every floor of the search is on the event floor, every plan on the same seeds in order
    rows = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    search = [r for r in rows if r["seed"] < 100]
    assert {r["floor"] for r in search} == {"event"}
    for label in {r["plan"] for r in search}:
        seeds = [r["seed"] for r in search if r["plan"] == label]
        assert seeds == list(range(len(seeds)))  # a prefix of 0-5: pruned plans stop early


def test_a_resumed_search_plays_no_floor_twice(tmp_path):
    case_path = planted_case(tmp_path)
    out = tmp_path / "plan"
    first = ["--case", str(case_path), "--out", str(out), *ARGS]
    first[first.index("--trials") + 1] = "3"
    assert plan.main(first) == 0
    played = len((out / "episodes.jsonl").read_text().splitlines())
    again = list(first)
    again[again.index("--trials") + 1] = "5"
    assert plan.main([*again, "--resume"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["tried"]["trials"] == 5
    rows = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    keys = [(r["floor"], r["plan"], r["seed"]) for r in rows]
    assert len(keys) == len(set(keys))  # none played twice
    assert summary["search"]["floors_played_now"] == len(rows) - played
    study = optuna.load_study(study_name="plan", storage=study_storage(out))
    assert len(study.trials) == 5


def test_a_pareto_search_keeps_the_front(tmp_path):
    case_path = planted_case(tmp_path)
    out = tmp_path / "front"
    args = ["--case", str(case_path), "--objective", "pareto", "--out", str(out), *ARGS]
    args[args.index("--trials") + 1] = "4"
    assert plan.main(args) == 0
    summary = json.loads((out / "summary.json").read_text())
    front = [p for p in summary["points"] if p["front"]]
    assert front
    for p in front:  # no point beats a front point on both
        assert not any(q["p80_s"] < p["p80_s"] and q["cost_mean"] < p["cost_mean"]
                       for q in summary["points"])
    assert tomllib.loads((out / "plan.toml").read_text())["case"]


def costly_crews_case(tmp_path):
    """The tiny case with levers RC 1-2 and the rebars' reorder point 0-0.5, and every cost but
    the RC crews' 5,000/h set to 0: one more RC crew is the fastest plan (about 0.7 x the
    makespan) but dearer (2 x the rate for 0.7 x the time: 1.4 x the cost), a reorder point
    saves one crane lift's wait (-120 s, 0.95 x; measured on seeds 0-11) at no crew cost, so
    it is the fastest plan no dearer than the case."""
    data = load_case(TINY_CASE).model_dump(mode="json")
    data["levers"] = {"crews": {"RC": {"min": 1, "max": 2}},
                      "materials": {"rebars": {"reorder_at": [0.0, 0.5]}}}
    data["cost"] = {"crew_rate_per_h": {"RC": 5000.0, "HIC": 0.0}, "crane_per_h": 0.0,
                    "overhead_per_h": 0.0}
    from cmdp_pymunk.cases.levers import variant_toml

    path = tmp_path / "costly_crews.toml"
    path.write_text(variant_toml(case_from_dict(data, "costly")), encoding="utf-8")
    return path


def test_cost_bound_by_hand():
    base = [{"seed": s, "finished": True, "cost": 100.0} for s in (1, 2, 3)]

    def rows(costs):
        return [{"seed": s, "finished": True, "cost": c}
                for s, c in zip((1, 2, 3), costs, strict=True)]

    # dearer on the mean: 330 / 300 = 1.1, violation 0.1; diffs 10, 20, 0: mean 10, sd 10,
    # t(0.975, 2) = 4.303: half-width 24.8, so the interval (-14.8, 34.8) is not wholly above 0
    b = cost_bound(rows([110.0, 120.0, 100.0]), base, 1.0)
    assert b["cost_ratio"] == pytest.approx(1.1) and b["cost_violation"] == pytest.approx(0.1)
    assert not b["clearly_over"]
    # diffs 10, 11, 12: mean 11, sd 1, half-width 2.48: (8.5, 13.5) lies above 0 ...
    b = cost_bound(rows([110.0, 111.0, 112.0]), base, 1.0)
    assert b["clearly_over"] and b["cost_violation"] == pytest.approx(0.11)
    # ... but not above a bound of 1.1 x (an allowance of 10 a floor), though over it on the mean
    b = cost_bound(rows([110.0, 111.0, 112.0]), base, 1.1)
    assert not b["clearly_over"] and b["cost_violation"] == pytest.approx(0.01)
    # cheaper: feasible (the violation is <= 0); only seeds both finished are paired
    b = cost_bound(rows([90.0, 95.0, None]), base, 1.0)
    assert b["cost_ratio"] == pytest.approx(185 / 200) and b["cost_violation"] < 0


def test_a_cost_bound_refuses_the_faster_dearer_plan_and_picks_the_planted_one(tmp_path):
    case_path = costly_crews_case(tmp_path)
    chosen = {}
    for name, extra in (("time", []), ("bound", ["--max-cost-ratio", "1.0"])):
        out = tmp_path / name
        assert plan.main(["--case", str(case_path), "--objective", "p80", "--out", str(out),
                          *ARGS, *extra]) == 0
        chosen[name] = json.loads((out / "summary.json").read_text())
    # on time alone the search takes the dearer crew
    assert chosen["time"]["chosen"]["crews"] == "HIC 1, RC 2"
    s = chosen["bound"]
    assert s["max_cost_ratio"] == 1.0
    # with the bound: the planted plan, the case's crews and a reorder point, faster and no
    # dearer on the held-out seeds
    assert s["chosen"]["crews"] == "HIC 1, RC 1"
    assert [c.split("=")[0] for c in s["chosen"]["changes"]] == ["rebars.reorder_at"]
    held = s["chosen"]["held_out"]
    assert held["makespan_diff_mean_s"] < 0 and held["p80_ratio"] < 1
    assert held["cost_diff_mean"] <= 0 and held["within_cost_bound"] is True
    # every RC=2 plan the search tried carries Optuna's constraint, violated; the others not
    study = optuna.load_study(study_name="plan", storage=study_storage(tmp_path / "bound"))
    told = [t for t in study.trials if t.constraints]
    dear = [t for t in told if t.user_attrs["plan"].startswith("RC=2")]
    assert dear and all(t.constraints["cost"] > 0.3 for t in dear)  # about 1.35 x
    assert all(t.constraints["cost"] <= 0 for t in told if t not in dear)
    assert s["tried"]["infeasible"] == len(dear) and s["tried"]["feasible_complete"] >= 2
    rows = (tmp_path / "bound" / "trials.csv").read_text().splitlines()
    assert rows[0].endswith(",cost_ratio,feasible")
    assert all(r.endswith(",False") for r in rows[1:] if '"RC=2' in r)
    # the confirmed plans are the feasible ones only
    assert all(not p["plan"].startswith("RC=2") for p in s["confirmation"]["plans"])


def test_a_bounded_pareto_search_keeps_a_front_of_feasible_plans(tmp_path):
    case_path = costly_crews_case(tmp_path)
    out = tmp_path / "front"
    args = ["--case", str(case_path), "--objective", "pareto", "--max-cost-ratio", "1.0",
            "--out", str(out), *ARGS]
    args[args.index("--trials") + 1] = "6"
    assert plan.main(args) == 0
    summary = json.loads((out / "summary.json").read_text())
    front = [p for p in summary["points"] if p["front"]]
    # NSGA-II's best_trials keeps feasible trials only: the dearer crew is never on the front
    assert front and all(p["feasible"] and p["cost_ratio"] <= 1.0 for p in front)
    assert not any(p["plan"].startswith("RC=2") for p in front)
    assert any(p["plan"].startswith("RC=2") and not p["feasible"] for p in summary["points"])
    assert summary["search"]["sampler"] == "NSGAIISampler"


def test_the_levers_file_is_the_built_in_floor():
    levers_file = TINY_CASE.parent / "precast_floor_levers.toml"
    levers = load_case(levers_file).model_dump(mode="json")
    built_in = load_case(None).model_dump(mode="json")
    assert levers.pop("levers") and built_in.pop("levers", None) is None
    levers["case"].pop("name"), built_in["case"].pop("name")
    assert levers == built_in
    keys = [lv.key for lv in search_space(load_case(levers_file))]
    # the default space's 8 levers and the three lift batches
    assert len(keys) == 11 and "rebars.crane_lift_quantity" in keys


@pytest.mark.parametrize("extra, words", [
    (["--search-seeds", "0-5", "--confirm-seeds", "5-9"], "share seeds [5]"),
    (["--resume"], "holds no plan search"),
    (["--min-seeds", "9", "--search-seeds", "0-3"], "--min-seeds 9"),
    (["--objective", "cost", "--max-cost-ratio", "1.0"], "--max-cost-ratio bounds the cost"),
    (["--max-cost-ratio", "0"], "--max-cost-ratio 0.0 is not a positive number"),
])
def test_bad_settings_are_refused_before_anything_runs(tmp_path, capsys, extra, words):
    out = tmp_path / "bad"
    assert plan.main(["--case", str(TINY_CASE), "--out", str(out), "--no-progress",
                      "--workers", "1", *extra]) == 2
    err = capsys.readouterr().err
    assert words in err and "fix:" in err
    assert not (out / "episodes.jsonl").exists()


@pytest.mark.slow
def test_the_same_search_on_one_or_two_workers_tries_the_same_plans(tmp_path):
    case_path = planted_case(tmp_path)
    trials = {}
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}"
        args = ["--case", str(case_path), "--objective", "cost", "--out", str(out), *ARGS]
        args[args.index("--workers") + 1] = workers
        assert plan.main(args) == 0
        trials[workers] = (out / "trials.csv").read_text()
    assert trials["1"] == trials["2"]
