"""``cmdp-simulate`` reports what a floor cost (``cmdp_pymunk.cost``): per seed in summary.json,
and over several seeds the cost's P50/P80 beside the makespan's in makespans.json."""

import json

import numpy as np
import pytest

from cmdp_pymunk import TINY_CASE, load_case
from cmdp_pymunk.cost import cost_percentiles, run_cost_fields
from training.commands import simulate

TINY = str(TINY_CASE)


def test_run_cost_fields_by_hand():
    case = load_case(TINY_CASE)  # no [cost]: crews 200/h, crane 150/h, overhead 250/h
    events = [type("E", (), {"kind": k})() for k in ("crane_done", "task_end", "crane_done")]
    out = run_cost_fields(case, 3600.0, events)
    # 1 h x (2 crews x 200 + 150 + 250) = 800; twice the crew rates: 1 h x (800 + 400) = 1200
    assert out == {"crane_lifts": 2, "cost": pytest.approx(800.0),
                   "cost_crew_rates_x2": pytest.approx(1200.0)}
    assert run_cost_fields(case, None, events)["cost"] is None  # not finished: no cost


def test_cost_percentiles_leave_out_runs_without_a_cost():
    runs = [{"cost": c, "cost_crew_rates_x2": c and 2 * c} for c in (100.0, None, 300.0, 200.0)]
    out = cost_percentiles(runs)
    # 100, 200, 300: P50 200; P80 at rank 0.8 x 2 = 1.6 -> 200 + 0.6 x 100 = 260
    assert out["cost_runs"] == 3
    assert out["cost_p50"] == pytest.approx(200.0) and out["cost_p80"] == pytest.approx(260.0)
    assert out["cost_crew_rates_x2_mean"] == pytest.approx(400.0)
    assert cost_percentiles([])["cost_p80"] is None


def test_simulate_reports_cost_per_seed_and_its_percentiles(tmp_path):
    out = tmp_path / "sim"
    assert simulate.main(["--case", TINY, "--out", str(out), "--episodes", "3", "--no-charts",
                          "--no-progress", "--fidelity", "event"]) == 0
    case = load_case(TINY_CASE)
    costs = []
    for seed in range(3):
        data = json.loads((out / f"seed-{seed}" / "summary.json").read_text())
        hours = data["makespan_s"] / 3600.0
        # recomputed from the makespan and the lifts: crews 2 x 200, crane 150, overhead 250
        assert data["cost"] == pytest.approx(hours * 800.0)
        assert data["cost_crew_rates_x2"] == pytest.approx(hours * 1200.0)
        assert data["crane_lifts"] >= 1  # the tiny floor's slab is hoisted
        costs.append(data["cost"])
    stats = json.loads((out / "makespans.json").read_text())
    assert stats["cost_p50"] == pytest.approx(float(np.percentile(costs, 50)))
    assert stats["cost_p80"] == pytest.approx(float(np.percentile(costs, 80)))
    assert stats["p80_s"] is not None  # beside the makespan's
    assert case.cost is None
