"""The re-planning solver (agents.replan): plumbing on the tiny case, by hand."""

from __future__ import annotations

import pytest
from conftest import play_floor

from agents.cpsat import conflict_cliques
from agents.replan import (
    Plan,
    ReplanEvaluator,
    ReplanSettings,
    remaining_seconds,
    solve_rest,
)
from agents.specs import evaluator_from_spec
from cmdp_pymunk.precedence import Pool
from cmdp_pymunk.state import Site

# Expected durations of the tiny case (conftest): X 120 s, K-A 60 + 30 s crane assistance,
# M-C 0.3 m3 at 0.1 m3/min = 180 s.


def test_remaining_seconds_by_hand(tiny_case):
    site = Site(tiny_case, 2)
    task = site.tasks[3]  # M-C, work 0.3
    task.progress = 0.1
    task.pace = 0.1 / 60  # 0.1 m3 a minute
    assert remaining_seconds(task, 180.0) == pytest.approx(120.0)
    task.pace = 0.0  # not drawn: the expected duration's share of what is left
    assert remaining_seconds(task, 180.0) == pytest.approx(120.0)


def test_plan_from_the_start_is_the_critical_path(tiny_case):
    # overhead 10 s a task: X-A 0-130, K-A 130-230, M-C 230-420; X-B 130-260 on the one
    # cleaning crew (after X-A, which the sum of ends puts first: it heads the chain).
    site = Site(tiny_case, 2)
    plan = solve_rest(site, ReplanSettings(limit=5.0, overhead_s=10.0),
                      conflict_cliques(tiny_case))
    assert plan.status == "optimal" and plan.makespan_s == 420.0
    assert plan.starts == {0: 0, 1: 130, 2: 130, 3: 230}


def test_a_task_in_progress_is_fixed_and_ended_ones_are_gone(tiny_case):
    # X-A ended, X-B half done at its expected pace (60 s left), K-A now: K-A 0-100 (crane
    # 0-30), M-C 100-290.
    site = Site(tiny_case, 2)
    site.tasks[0].pool = Pool.END
    site.tasks[1].pool = Pool.QUEUE
    x_b = site.tasks[2]
    x_b.pool, x_b.progress, x_b.pace = Pool.ON, 0.5, 1 / 120
    plan = solve_rest(site, ReplanSettings(limit=5.0, overhead_s=10.0),
                      conflict_cliques(tiny_case))
    assert plan.starts == {1: 0, 3: 100} and plan.makespan_s == 290.0


def test_settings_and_spec_errors_name_the_fix():
    with pytest.raises(ValueError, match="limit"):
        ReplanSettings(limit=0)
    with pytest.raises(ValueError, match="overhead_s"):
        ReplanSettings(overhead_s=-1)
    with pytest.raises(ValueError, match="window=SECONDS"):
        evaluator_from_spec("replan:windw=3")
    with pytest.raises(ValueError, match="plan inside plans"):
        evaluator_from_spec("replan:base=replan")
    ev = evaluator_from_spec("replan:limit=0.5+overhead=30+window=60+base=nearest")
    assert ev.settings == ReplanSettings(limit=0.5, overhead_s=30.0, window_s=60.0)


def test_replan_finishes_the_floor_the_same_way_twice(tiny_case):
    first, second = ReplanEvaluator(), ReplanEvaluator()
    a = play_floor(first, tiny_case)
    b = play_floor(second, tiny_case)
    assert a.engine.site.done and a.log.events == b.log.events
    assert first.plans and all(isinstance(p, Plan) for p in first.plans)
    assert first.summary()["plans"] == len(first.plans)


def test_cmdp_simulate_runs_replan_and_reports_it_under_its_own_key(tmp_path):
    import json

    import cmdp_pymunk
    from training.commands import simulate

    out = tmp_path / "run"
    assert simulate.main(["--case", str(cmdp_pymunk.TINY_CASE), "--out", str(out),
                          "--evaluator", "replan:overhead=10", "--no-charts",
                          "--no-progress"]) == 0
    data = json.loads((out / "summary.json").read_text())
    assert data["all_finished"] and data["lookahead"] is None
    assert data["replan"]["plans"] >= 1 and data["replan"]["overhead_s"] == 10.0
