"""The makespan lower bound, worked out by hand on the tiny case."""

import pytest

from cmdp_pymunk import load_case
from cmdp_pymunk.bounds import expected_duration_s, lower_bound


def test_tiny_case_lower_bound(tiny_case):
    # X: 2 min = 120 s; K: 1 min + 30 s crane assistance = 90 s; M: 0.3 m3 at 0.1 m3/min = 180 s
    durations = [expected_duration_s(tiny_case, t) for t in tiny_case.tasks]
    assert durations == pytest.approx([120.0, 90.0, 120.0, 180.0])
    lb = lower_bound(tiny_case)
    # critical path X-A -> K-A -> M-C: 120 + 90 + 180 = 390
    assert lb.critical_path == ("X-A", "K-A", "M-C")
    assert lb.critical_path_s == pytest.approx(390.0)
    # per crew type: XC 240 / 1, KC 90 / 1, MC 180 / 2 crews = 90
    assert lb.per_crew_type_s == pytest.approx({"XC": 240.0, "KC": 90.0, "MC": 90.0})
    assert lb.lower_bound_s == pytest.approx(390.0)


def test_crew_bound_wins_when_work_piles_on_one_crew(tiny_case):
    from conftest import tiny_dict

    from cmdp_pymunk.cases.load import case_from_dict

    data = tiny_dict()
    data["crew_types"]["XC"]["duration_mean_min"] = 5.0  # X: 300 s each, 600 s on one crew
    lb = lower_bound(case_from_dict(data))
    assert lb.per_crew_type_s["XC"] == pytest.approx(600.0)
    assert lb.critical_path_s == pytest.approx(300 + 90 + 180)
    assert lb.lower_bound_s == pytest.approx(600.0)


def test_builtin_case_bound_is_a_fraction_of_the_papers_makespan():
    lb = lower_bound(load_case())
    assert 10000 < lb.lower_bound_s < 33000
