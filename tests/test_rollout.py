"""The rollout library: reach rate, makespan statistics, a whole tiny episode."""

import pytest

from agents.specs import evaluator_from_spec, make_navigator, model_path
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.report import crew_summary, episode_reach_rate, makespan_stats, reach_rate
from cmdp_pymunk.rollout import run_episode


def test_reach_rate_counts_each_timeout_as_a_miss():
    assert reach_rate(9, 1) == pytest.approx(0.9)  # 9 / (9 + 1)
    assert reach_rate(3, 0) == 1.0
    assert reach_rate(0, 0) == 0.0  # no attempt: no division by zero


def test_makespan_stats_over_finished_episodes_only():
    rows = [{"makespan_s": 100.0, "reach_rate": 1.0, "lower_bound": {"lower_bound_s": 50.0}},
            {"makespan_s": 300.0, "reach_rate": 0.8, "lower_bound": {"lower_bound_s": 50.0}},
            {"makespan_s": None, "reach_rate": 0.6, "lower_bound": {"lower_bound_s": 50.0}}]
    stats = makespan_stats(rows)
    # finished: 100 and 300 -> mean 200, population std 100, 200 / 50 = 4
    assert stats["episodes"] == 3 and stats["finished"] == 2
    assert stats["mean_s"] == 200.0 and stats["std_s"] == 100.0
    assert stats["mean_over_lower_bound"] == 4.0
    assert stats["mean_reach_rate"] == pytest.approx(0.8)  # (1 + 0.8 + 0.6) / 3
    assert stats["makespans_s"] == [100.0, 300.0, None]
    # percentiles of (100, 300), linear: 100 + q / 100 * (300 - 100)
    assert (stats["p50_s"], stats["p80_s"], stats["p90_s"]) == pytest.approx((200, 260, 280))


def test_run_episode_finishes_the_tiny_case(tiny_case):
    engine = Engine(tiny_case, evaluator=evaluator_from_spec("priority"))
    navigator = make_navigator("scripted", engine)
    episode = run_episode(engine, navigator, seed=1, stall_s=3600.0, progress=False)
    assert episode.stalled is None and episode.makespan_s == engine.site.time_s
    summary = crew_summary(engine)
    assert set(summary) == {c.id for c in tiny_case.crews}
    reaches = sum(c["reaches"] for c in summary.values())
    misses = sum(c["reach_timeouts"] for c in summary.values())
    assert reaches > 0 and episode_reach_rate(engine) == reach_rate(reaches, misses)


def test_a_missing_model_file_is_named(tmp_path):
    with pytest.raises(ValueError, match="--navigator .*nope.zip.*no such model file"):
        model_path(str(tmp_path / "nope.zip"), "--navigator")


def test_makespan_stats_over_the_seed_bound():
    from cmdp_pymunk.report import makespan_stats

    rows = [{"makespan_s": m, "reach_rate": 1.0, "seed_bound_s": b}
            for m, b in ((150.0, 100.0), (300.0, 150.0), (None, 120.0))]
    stats = makespan_stats(rows)
    # bounds 100, 150, 120: mean 123.33; ratios of the finished 1.5 and 2.0: mean 1.75
    assert stats["seed_bound_mean_s"] == pytest.approx(370.0 / 3)
    assert stats["mean_over_seed_bound"] == pytest.approx(1.75)
    assert makespan_stats([{"makespan_s": 1.0, "reach_rate": 1.0}])["mean_over_seed_bound"] \
        is None


def test_stall_text_reads_a_report_as_prose():
    """A hand-made stall report (the shape ``stall_report`` gives) in prose, word for word."""
    from cmdp_pymunk.report import stall_text

    report = {"after_s": 3600.0, "time_s": 21183.0, "tasks": 36, "tasks_ended": 33,
              "tasks_on": ["F-12"], "tasks_queued": ["F-14", "R-3"],
              "crews": [
                  {"crew": "FC-2", "type": "FC", "radius_m": 1.13, "activity": "navigating",
                   "position_m": [12.3, -4.0], "targets": ["P-24"], "task": None,
                   "steps_since_reach": 3600,
                   "heading_for": {"target": "P-24", "task": "F-14",
                                   "position_m": [12.3, 2.2], "distance_m": 6.2},
                   "way_m": [[12.3, -4.0], [12.3, -1.0], [16.3, 2.0]]},
                  {"crew": "FC-1", "type": "FC", "radius_m": 1.13, "activity": "tasking",
                   "position_m": [3.0, 1.5], "targets": [], "task": "F-12",
                   "steps_since_reach": 0, "heading_for": None}]}
    assert stall_text(report).splitlines() == [
        "At t = 21,183 s no task had moved on for 3,600 s; 33 of 36 tasks ended.",
        "FC-2 (FC, 1.13 m radius) has held a target for 3,600 s without reaching one: it walks "
        "to task F-14's work point at P-24 (12.30, 2.20) m and stands at (12.30, -4.00) m, "
        "6.2 m from it; its planned way runs 8.0 m from there. The nearest crew, FC-1, is "
        "8.5 m from it (edge to edge).",  # way: 3 m, then a 3-4-5 step; 10.80 - 2 x 1.13 m
        "FC-1 (FC, 1.13 m radius) is working on F-12, at (3.00, 1.50) m.",
        "Tasks on: F-12; queued: F-14, R-3."]
