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


# -- issue 32: the pace law (Jensen), loading, and a bound per seed -----------------------------

def test_clipped_normal_mean_by_hand():
    from cmdp_pymunk.bounds import clipped_normal_mean

    # a duration crew's clip far below its mean (JCC: N(11.8, 1.2), clip 1.18, a = -8.85):
    # the mean duration is unchanged
    assert clipped_normal_mean(11.8, 1.2, 1.18) == pytest.approx(11.8, rel=1e-12)
    # a wide law: N(10, 10) clipped at 1, a = -0.9, Phi(-0.9) = 0.184060, phi(-0.9) = 0.266085:
    # 1 * 0.184060 + 10 * 0.815940 + 10 * 0.266085 = 11.004310
    assert clipped_normal_mean(10.0, 10.0, 1.0) == pytest.approx(11.004310, abs=1e-5)
    assert clipped_normal_mean(2.0, 0.0, 0.2) == 2.0  # no spread: the mean itself


def test_clipped_normal_inverse_mean_rc_law():
    import numpy as np

    from cmdp_pymunk.bounds import clipped_normal_inverse_mean

    # RC: N(0.021, 0.007) m3/min clipped at 0.0021. The clipped mass alone: Phi(-2.7) = 0.003467
    # over 0.0021 = 1.651 min/m3; the whole E[1/eff] = 56.786 min/m3 against 1/0.021 = 47.619:
    # ratio 1.1925 (the mean-pace bound takes reinforcing 19 % too short)
    value = clipped_normal_inverse_mean(0.021, 0.007, 0.0021)
    assert value == pytest.approx(56.786, abs=1e-3)
    assert value * 0.021 == pytest.approx(1.1925, abs=1e-4)
    # recomputed independently: the draw the engine makes, a million times
    draws = np.maximum(np.random.default_rng(7).normal(0.021, 0.007, 1_000_000), 0.0021)
    assert float(np.mean(1.0 / draws)) == pytest.approx(value, rel=5e-3)
    assert clipped_normal_inverse_mean(0.1, 0.0, 0.01) == pytest.approx(10.0)  # no spread


def test_builtin_jensen_ratios():
    from cmdp_pymunk.bounds import jensen_ratio

    case = load_case()
    ratios = {ct: jensen_ratio(spec) for ct, spec in case.crew_types.items()}
    # RC N(0.021, 0.007): 1.1925; FC N(0.495, 0.134): 1.1018; duration crews: 1
    assert ratios["RC"] == pytest.approx(1.1925, abs=1e-4)
    assert ratios["FC"] == pytest.approx(1.1018, abs=1e-4)
    assert ratios["JCC"] == ratios["HIC"] == ratios["GC"] == pytest.approx(1.0)


def test_loading_by_hand(tiny_case):
    from cmdp_pymunk.bounds import in_task_loading_s, loading_s

    by_id = {t.id: t for t in tiny_case.tasks}
    # M-C: 0.3 m3 of bars at 0.6 m3/min = 0.5 min = 30 s; the crew starts with at most its
    # capacity 0.2, so (0.3 - 0.2) / 0.6 min = 10 s fall inside the task
    assert loading_s(tiny_case, by_id["M-C"]) == pytest.approx(30.0)
    assert in_task_loading_s(tiny_case, by_id["M-C"]) == pytest.approx(10.0)
    assert loading_s(tiny_case, by_id["X-A"]) == in_task_loading_s(tiny_case, by_id["X-A"]) == 0


def test_expected_work_by_crew_type(tiny_case):
    from cmdp_pymunk.bounds import expected_task_duration_s, expected_work_by_crew_type

    # tiny laws have no spread worth clipping: the expected durations are the mean-pace ones
    assert [expected_task_duration_s(tiny_case, t) for t in tiny_case.tasks] == \
        pytest.approx([120.0, 90.0, 120.0, 180.0])
    # XC 2 x 120 on one crew; KC 90; MC (180 + 30 loading) over 2 crews = 105
    assert expected_work_by_crew_type(tiny_case) == pytest.approx(
        {"XC": 240.0, "KC": 90.0, "MC": 105.0})


def test_builtin_binding_crew_type_is_reinforcing():
    from cmdp_pymunk.bounds import expected_work_by_crew_type

    work = expected_work_by_crew_type(load_case())
    # RC: 21 tasks of 0.5 m3 = 10.5 m3 / 0.021 m3/min = 30,000 s at the mean pace, x 1.1925 =
    # 35,775 s, + loading 10.5 m3 / 0.1 m3/min = 6,300 s, over 2 crews: 21,037.5 s. FC: 252 m2 /
    # 0.495 m2/min = 30,545 s x 1.1018 = 33,654 s, + 252 m2 / 5 m2/min = 3,024 s, over 2 crews:
    # 18,339 s. The mean-pace bound had FC (15,273 s) over RC (15,000 s)
    assert work["RC"] == pytest.approx(21037.5, abs=1.0)
    assert work["FC"] == pytest.approx(18338.9, abs=1.0)
    assert max(work, key=work.get) == "RC"


def test_seed_bound_on_the_tiny_case_by_hand(tiny_case):
    from cmdp_pymunk.bounds import seed_lower_bound
    from cmdp_pymunk.streams import RandomStreams

    # the paces seed 0 draws: X-A (task 0) and X-B (task 2) from N(2, 0.3) minutes; K and M
    # have no spread (K-A 60 s + 30 s crane = 90 s, M-C 0.3 / 0.1 min = 180 s)
    streams = RandomStreams(0)
    x_a = max(streams.pace(0).normal(2.0, 0.3), 0.2) * 60.0
    x_b = max(streams.pace(2).normal(2.0, 0.3), 0.2) * 60.0
    bound = seed_lower_bound(tiny_case, 0)
    # critical path X-A -> K-A -> M-C with M-C's 10 s of in-task loading
    assert bound.critical_path == ("X-A", "K-A", "M-C")
    assert bound.critical_path_s == pytest.approx(x_a + 90.0 + 190.0)
    # per crew type, head + (work - crews x preload) / crews + tail:
    # XC: 0 + (x_a + x_b) / 1 + 0 (X-B has no successor);
    # KC: x_a + 90 / 1 + 190 (M-C after it) = x_a + 280;
    # MC: head x_a + 90; work 180 + 30 loading, less 2 crews x a carry of 0.2 m3 / 0.6 m3/min
    # = 20 s each: (210 - 40) / 2 = 85; tail 0: x_a + 175
    assert bound.per_crew_type_s == pytest.approx(
        {"XC": x_a + x_b, "KC": x_a + 280.0, "MC": x_a + 175.0})
    assert bound.seed_bound_s == pytest.approx(max(x_a + 280.0, x_a + x_b))


def test_heads_tails_and_the_crew_type_bound_by_hand(tiny_case):
    from cmdp_pymunk.bounds import crew_type_bound_s, heads_and_tails, preload_s

    # durations X-A 100, K-A 90, X-B 130, M-C 190: heads 0, 100, 0, 190; tails 280, 190, 0, 0
    head, tail = heads_and_tails(tiny_case, {"X-A": 100.0, "K-A": 90.0, "X-B": 130.0,
                                             "M-C": 190.0})
    assert head == {"X-A": 0.0, "K-A": 100.0, "X-B": 0.0, "M-C": 190.0}
    assert tail == {"X-A": 280.0, "K-A": 190.0, "X-B": 0.0, "M-C": 0.0}
    assert preload_s(tiny_case, "MC") == pytest.approx(20.0)  # 0.2 m3 at 0.6 m3/min
    assert preload_s(tiny_case, "XC") == 0.0
    # 100 + (500 - 2 x 20) / 2 + 50 = 380; preloading more than the work leaves head + tail
    assert crew_type_bound_s(100.0, 500.0, 2, 20.0, 50.0) == pytest.approx(380.0)
    assert crew_type_bound_s(100.0, 30.0, 2, 20.0, 50.0) == pytest.approx(150.0)


def test_no_recorded_makespan_beats_its_seed_bound():
    import csv
    import json
    from pathlib import Path

    from cmdp_pymunk import TINY_CASE
    from cmdp_pymunk.bounds import seed_lower_bound

    data = Path(__file__).resolve().parent / "data"
    builtin = load_case()
    golden = json.loads((data / "golden_simulate.json").read_text(encoding="utf-8"))["seeds"]
    for seed, run in golden.items():  # the built-in case, Eq. 9, scripted navigator
        assert run["makespan_s"] >= seed_lower_bound(builtin, int(seed)).seed_bound_s
    tiny = load_case(TINY_CASE)
    with open(data / "golden_evaluate_tiny.csv", encoding="utf-8") as f:
        for row in csv.DictReader(f):  # the packaged tiny case, four strategies
            assert float(row["makespan_s"]) >= seed_lower_bound(tiny, int(row["seed"])).seed_bound_s
