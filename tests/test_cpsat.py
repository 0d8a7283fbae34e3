"""The CP-SAT schedule bound and its plan (agents/cpsat.py), on the tiny case by hand."""

import pytest
from conftest import tiny_dict

from agents.cpsat import PlanEvaluator, conflict_cliques, resource_cut_s, solve, task_conflicts
from cmdp_pymunk.bounds import lower_bound
from cmdp_pymunk.cases.load import case_from_dict

# Expected durations of the tiny case (conftest): X (cleaning crew, 2 min) 120 s;
# K-A (1 min + 30 s crane assistance) 90 s; M-C (0.3 m3 at 0.1 m3/min) 180 s.


def test_tiny_optimum_is_its_critical_path(tiny_case):
    # X-A -> K-A -> M-C: 120 + 90 + 180 = 390 s; X-B (120 s) after X-A on the one cleaning
    # crew ends at 240 s, off the critical path.
    result = solve(tiny_case, time_limit_s=10)
    assert result.optimal and result.bound_s == result.makespan_s == 390.0
    assert result.starts_s["X-A"] == 0 and result.starts_s["K-A"] == 120
    assert result.starts_s["M-C"] == 210 and result.gap == 0.0


def conflict_case():
    """No X-B; K-A no longer waits for X-A; M-C is 0.05 m3 (30 s). X-A's and K-A's areas
    overlap (same component), so they cannot run together."""
    data = tiny_dict()
    data["tasks"] = [t for t in data["tasks"] if t["id"] != "X-B"]
    data["tasks"][1]["predecessors"] = []
    data["tasks"][2]["work"] = data["tasks"][2]["material_quantity"] = 0.05
    return case_from_dict(data, "conflict.toml")


def test_conflicting_areas_never_overlap():
    # Without the conflict: X-A 0-120 beside K-A 0-90, M-C 90-120 -> 120 s.
    # With it: K-A 0-90 then X-A 90-210 (M-C 90-120 beside X-A: their areas do not meet)
    # -> 210 s; X-A first would give 120 + 90 + 30 = 240 s.
    case = conflict_case()
    assert (0, 1) in task_conflicts(case)  # X-A and K-A
    result = solve(case, time_limit_s=10)
    assert result.optimal and result.makespan_s == 210.0
    assert result.starts_s["K-A"] == 0 and result.starts_s["X-A"] == 90


def test_resource_cut_by_hand(tiny_case):
    # cleaning crew: X-A has head 0 and tail 270 (K-A + M-C): 0 + 120 / 1 + 270 = 390;
    # hoisting: 120 + 90 + 180 = 390; rebar crews: 210 + 180 / 2 + 0 = 300.
    cut, crew_type = resource_cut_s(tiny_case)
    assert cut == pytest.approx(390.0) and crew_type in ("XC", "KC")
    assert cut >= lower_bound(tiny_case).lower_bound_s


def test_cliques_cover_every_conflict(tiny_case):
    pairs = set(task_conflicts(tiny_case))
    covered = {(a, b) for c in conflict_cliques(tiny_case) for a in c for b in c if a < b}
    assert pairs == covered


def test_plan_evaluator_prefers_the_earliest_planned_task(tiny_env):
    ev = PlanEvaluator(time_limit_s=10)
    ev.prepare(tiny_env.case)  # solves the case's plan (the engine does this when given it)
    # X-A starts at 0 of 390 s -> 1.0; X-B at 120 (or later) -> at most 1 - 120/390
    assert ev.priorities["X-A"] == 1.0 and ev.priorities["X-B"] <= 1 - 120 / 390 + 1e-9
    site = tiny_env.engine.site
    crew = site.crews[0]
    values = ev.target_values(crew, site, tiny_env.engine.positions[0])
    best = max(values, key=values.get)
    assert site.tasks[crew.scope[best]].id == "X-A"


def test_simulate_reports_the_cpsat_bound_and_replays_the_plan(tmp_path):
    import json

    import cmdp_pymunk
    from training.commands import simulate

    tiny = cmdp_pymunk.TINY_CASE
    out = tmp_path / "run"
    assert simulate.main(["--case", str(tiny), "--evaluator", "cpsat", "--cpsat-s", "5",
                          "--out", str(out), "--no-charts", "--no-progress"]) == 0
    data = json.loads((out / "summary.json").read_text())
    assert data["all_finished"]
    cp = data["cpsat"]
    assert cp["optimal"] and cp["bound_s"] >= data["lower_bound"]["lower_bound_s"] - 1
    assert data["makespan_over_cpsat_bound"] == pytest.approx(data["makespan_s"]
                                                              / cp["bound_s"])
