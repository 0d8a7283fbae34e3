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


@pytest.mark.parametrize("extra, words", [
    (["--search-seeds", "0-5", "--confirm-seeds", "5-9"], "share seeds [5]"),
    (["--resume"], "holds no plan search"),
    (["--min-seeds", "9", "--search-seeds", "0-3"], "--min-seeds 9"),
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
