"""What disruptions struck an episode and what they cost (issue 31, item 6): the counts and
downtimes read from the event log (``disruptions.struck``), the delay against the same seed on
the case without them (``disruptions.undisrupted``, ``report.disruption_cost``,
``training.runs.runner.cost_fields``), and both in ``cmdp-simulate`` and ``cmdp-evaluate``.

On the tiny case of ``conftest`` with the priority heuristic and the scripted navigator, seed 0
(``tests/test_disruptions.py`` works its times out): X-1 works X-A from 4 to 126, and K-1's
crane request for K-A comes when K-A starts, at 129 (3 s after X-A ends).
"""

from __future__ import annotations

import csv
import json

import pytest
from conftest import tiny_dict

from agents.navigator import Navigator
from cmdp_pymunk import disruptions
from cmdp_pymunk.cases.load import TINY_CASE, case_from_dict
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.events import Event
from cmdp_pymunk.report import disruption_cost, disruption_summary, struck_text
from training.runs.runner import EpisodeRunner, cost_fields

# One absence of X-1 [50, 110) and one crane breakdown [140, 240): scheduled, so the same on
# every seed.
HAND = {"absences": [{"crew": "X-1", "at_s": 50.0, "duration_s": 60.0}],
        "crane_breakdowns": [{"at_s": 140.0, "duration_s": 100.0}]}
# Random ones of every kind: tests/test_disruptions.py's profile; they differ per seed.
from test_disruptions import RANDOM  # noqa: E402


def tiny(extra: dict | None):
    data = tiny_dict()
    if extra is not None:
        data["disruptions"] = extra
    return case_from_dict(data, "tiny.toml")


def play(case, seed: int = 0) -> Engine:
    """One floor with the priority heuristic and the scripted navigator, as the commands
    build it (``park_idle``), driven here second by second without the episode library."""
    engine = Engine(case, evaluator="priority", park_idle=True, max_time_s=5000.0)
    engine.reset(seed=seed)
    navigator = Navigator()
    navigator.reset(seed)
    while not engine.site.done and engine.site.time_s < 5000.0:
        engine.advance(navigator.actions(engine))
    return engine


# -- what struck ---------------------------------------------------------------------------

def test_struck_from_a_hand_made_log():
    log = [Event(10.0, "disruption_start", "", "crane", "crane_breakdown"),
           Event(20.0, "disruption_start", "X-1", "X-1", "absence"),
           Event(25.0, "disruption_start", "M-1", "M-1", "absence"),
           Event(30.0, "disruption_end", "", "crane", "crane_breakdown"),
           Event(40.0, "disruption_end", "X-1", "X-1", "absence"),
           Event(60.0, "disruption_start", "", "crane", "crane_breakdown"),
           Event(70.0, "disruption_end", "", "crane", "crane_breakdown"),
           Event(80.0, "disruption_start", "", "plane", "weather"),
           Event(90.0, "task_finish", "X-1", "A")]
    # crane: [10, 30) and [60, 70): 2, 30 s; absences: X-1 [20, 40) and M-1 from 25 to the
    # end at 100, still away: 2, 20 + 75 = 95 s; weather from 80 to the end: 1, 20 s
    assert disruptions.struck(log, 100.0) == {
        "crane_breakdown": {"count": 2, "downtime_s": 30.0},
        "late_delivery": {"count": 0, "downtime_s": 0.0},
        "absence": {"count": 2, "downtime_s": 95.0},
        "weather": {"count": 1, "downtime_s": 20.0}}


def test_counts_and_downtimes_by_hand_on_the_tiny_case():
    # X-1 away [50, 110): 60 s, on X-A, which ends at 186 instead of 126; K-A starts and asks
    # for the crane at 189 (129 + 60). The crane is down [140, 240): 100 s, of which K-1
    # waits for it from 189 to 240, 51 crew-seconds.
    e = play(tiny(HAND))
    assert disruption_summary(e) == {
        "crane_breakdown": {"count": 1, "downtime_s": 100.0, "idle_crew_s": 51},
        "late_delivery": {"count": 0, "downtime_s": 0.0, "idle_crew_s": 0},
        "absence": {"count": 1, "downtime_s": 60.0, "idle_crew_s": 60},
        "weather": {"count": 0, "downtime_s": 0.0, "idle_crew_s": 0}}
    assert struck_text(disruption_summary(e)) == \
        "1 crane breakdown (100 s down), 1 absence (60 s down)"


def test_a_window_after_the_floor_ended_never_struck():
    e = play(tiny({"crane_breakdowns": [{"at_s": 4000.0, "duration_s": 100.0}]}))
    assert e.makespan_s < 4000.0
    assert disruption_summary(e)["crane_breakdown"] == {"count": 0, "downtime_s": 0.0,
                                                        "idle_crew_s": 0}
    assert struck_text(disruption_summary(e)) == "no disruption struck"


# -- what they cost: the paired difference of two runs -------------------------------------

def test_the_undisrupted_case_is_the_case_never_disrupted():
    plain, stripped = play(tiny(None)), play(disruptions.undisrupted(tiny(RANDOM)))
    assert stripped.case.disruptions == tiny(None).disruptions
    assert stripped.log.events == plain.log.events


@pytest.mark.parametrize("extra, seed", [(HAND, 0), (RANDOM, 3), (RANDOM, 4)])
def test_the_reported_delay_is_the_paired_difference_of_two_runs(extra, seed):
    with_them, without = play(tiny(extra), seed), play(tiny(None), seed)
    assert with_them.makespan_s and without.makespan_s
    delay = with_them.makespan_s - without.makespan_s
    if extra is HAND:
        assert delay > 0
    runner = EpisodeRunner(tiny(extra), stall_s=None, max_time_s=5000.0)
    row = runner.run("priority", "scripted", seed)
    undisrupted = runner.run("priority", "scripted", seed, undisrupted=True)
    assert row["makespan_s"] == with_them.makespan_s
    cost = cost_fields(row, undisrupted)
    assert cost["undisrupted_makespan_s"] == without.makespan_s
    assert cost["disruption_delay_s"] == delay
    assert cost["disruption_delay_pct"] == pytest.approx(100 * delay / without.makespan_s)
    assert {k: row[k] for k in ("absence_count", "absence_downtime_s")} == {
        "absence_count": disruption_summary(with_them)["absence"]["count"],
        "absence_downtime_s": disruption_summary(with_them)["absence"]["downtime_s"]}


def test_no_cost_without_both_makespans():
    assert disruption_cost(600.0, 500.0) == {"undisrupted_makespan_s": 500.0, "delay_s": 100.0,
                                             "delay_pct": 20.0, "by_kind": None}
    assert disruption_cost(None, 500.0)["delay_s"] is None  # the disrupted floor stalled
    assert disruption_cost(600.0, None)["delay_pct"] is None
    assert cost_fields({"makespan_s": 600.0}, None) == {
        "undisrupted_makespan_s": None, "disruption_delay_s": None,
        "disruption_delay_pct": None}


# -- the commands --------------------------------------------------------------------------

DISRUPTED_TOML = """
[[disruptions.crane_breakdowns]]
at_s = 100.0
duration_s = 300.0

[[disruptions.absences]]
crew = "RC-1"
at_s = 100.0
duration_s = 150.0
"""


@pytest.fixture
def disrupted_file(tmp_path):
    path = tmp_path / "tiny_disrupted.toml"
    path.write_text(TINY_CASE.read_text(encoding="utf-8") + DISRUPTED_TOML, encoding="utf-8")
    return path


@pytest.fixture
def never_undisrupted(monkeypatch):
    """Fails a test that plays a floor without its disruptions."""
    def refuse(case):
        raise AssertionError("played the case without its disruptions")

    monkeypatch.setattr(disruptions, "undisrupted", refuse)


def test_simulate_reports_what_struck_and_what_it_cost(tmp_path, disrupted_file, capsys):
    from training.commands import simulate

    plain, out = tmp_path / "plain", tmp_path / "disrupted"
    assert simulate.main(["--case", str(TINY_CASE), "--out", str(plain), "--episodes", "2",
                          "--no-charts", "--no-progress"]) == 0
    assert simulate.main(["--case", str(disrupted_file), "--out", str(out), "--episodes", "2",
                          "--workers", "2", "--no-charts", "--no-progress"]) == 0
    delays = []
    for seed in (0, 1):
        data = json.loads((out / f"seed-{seed}" / "summary.json").read_text())
        base = json.loads((plain / f"seed-{seed}" / "summary.json").read_text())
        # RC-1 away [100, 250); the crane down [100, 400): struck on every seed
        assert data["disruptions"]["absence"] == {"count": 1, "downtime_s": 150.0,
                                                  "idle_crew_s": 150}
        assert data["disruptions"]["crane_breakdown"]["count"] == 1
        assert data["disruptions"]["crane_breakdown"]["downtime_s"] == 300.0
        cost = data["disruption_cost"]
        assert cost["undisrupted_makespan_s"] == base["makespan_s"]  # the other run's
        assert cost["delay_s"] == data["makespan_s"] - base["makespan_s"]
        assert cost["by_kind"] == data["disruptions"] and cost["undisrupted_finished"]
        assert base["disruptions"] is None and base["disruption_cost"] is None
        delays.append(cost["delay_s"])
    stats = json.loads((out / "makespans.json").read_text())
    assert stats["disruption_cost"]["paired_seeds"] == 2
    assert stats["disruption_cost"]["delay_mean_s"] == pytest.approx(sum(delays) / 2)
    assert stats["disruptions"]["absence"]["downtime_s"] == 150.0
    assert json.loads((plain / "makespans.json").read_text())["disruption_cost"] is None
    lines = (out / "makespans.csv").read_text().splitlines()
    assert lines[0].endswith(",reach_rate,undisrupted_makespan_s,disruption_delay_s")
    assert lines[1].split(",")[-1] == str(delays[0])
    printed = capsys.readouterr().out
    assert "seed 0: 1 crane breakdown (300 s down), 1 absence (150 s down); they cost" in printed
    assert "a floor (" in printed and "on the same 2 seeds without them" in printed


def test_simulate_without_disruptions_plays_each_seed_once(tmp_path, never_undisrupted):
    from training.commands import simulate

    assert simulate.main(["--case", str(TINY_CASE), "--out", str(tmp_path), "--no-charts",
                          "--no-progress"]) == 0
    data = json.loads((tmp_path / "summary.json").read_text())
    assert data["disruptions"] is None and data["disruption_cost"] is None


def test_no_disruption_cost_counts_but_does_not_measure(tmp_path, disrupted_file,
                                                        never_undisrupted, capsys):
    from training.commands import simulate

    assert simulate.main(["--case", str(disrupted_file), "--out", str(tmp_path), "--no-charts",
                          "--no-progress", "--no-disruption-cost"]) == 0
    data = json.loads((tmp_path / "summary.json").read_text())
    assert data["disruptions"]["absence"]["count"] == 1 and data["disruption_cost"] is None
    assert "cost not measured (--no-disruption-cost)" in capsys.readouterr().out


def test_evaluate_rows_and_summaries_carry_the_cost(tmp_path, disrupted_file):
    from training.commands import evaluate_strategies as compare

    out = tmp_path / "eval"
    assert compare.main(["--case", str(disrupted_file), "--seeds", "0-1", "--strategies",
                         "priority,nearest", "--workers", "1", "--out", str(out),
                         "--no-progress", "--no-figures"]) == 0
    rows = list(csv.DictReader((out / "episodes.csv").open()))
    # the tiny case undisrupted, seeds 0 and 1: tests/data/golden_evaluate_tiny.csv
    golden = {r["seed"]: r["makespan_s"] for r in csv.DictReader(
        (TINY_CASE.parents[2] / "tests" / "data" / "golden_evaluate_tiny.csv").open())
        if r["strategy"] == "priority"}
    for r in rows:
        assert r["absence_count"] == "1" and float(r["absence_downtime_s"]) == 150.0
        assert r["crane_breakdown_count"] == "1"
        if r["strategy"] == "priority":
            assert r["undisrupted_makespan_s"] == golden[r["seed"]]
        assert float(r["disruption_delay_s"]) == \
            float(r["makespan_s"]) - float(r["undisrupted_makespan_s"])
    header = (out / "episodes.csv").read_text().splitlines()[0]
    assert header.endswith("idle_weather,crane_breakdown_count,crane_breakdown_downtime_s,"
                           "late_delivery_count,late_delivery_downtime_s,absence_count,"
                           "absence_downtime_s,weather_count,weather_downtime_s,"
                           "undisrupted_makespan_s,disruption_delay_s,disruption_delay_pct,seed_bound_s,"
                           "fidelity,crane_lifts,cost,cost_crew_rates_x2")  # cost: docs/levers.md
    summary = json.loads((out / "summary.json").read_text())
    mine = [float(r["disruption_delay_s"]) for r in rows if r["strategy"] == "priority"]
    assert summary[0]["disruption_cost_seeds"] == 2
    assert summary[0]["disruption_delay_mean_s"] == pytest.approx(sum(mine) / 2)
    assert summary[0]["absence_count_mean"] == 1.0
    assert "disruptions' delay (s) ± 95 % CI" in (out / "summary.md").read_text()
    log = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    assert all("disruption_delay_s" in r for r in log)


def test_evaluate_without_disruptions_plays_each_episode_once(tmp_path, never_undisrupted):
    from training.commands import evaluate_strategies as compare

    assert compare.main(["--case", str(TINY_CASE), "--seeds", "0", "--strategies", "priority",
                         "--workers", "1", "--out", str(tmp_path), "--no-progress",
                         "--no-figures"]) == 0
    row = next(csv.DictReader((tmp_path / "episodes.csv").open()))
    assert row["undisrupted_makespan_s"] == "" and row["absence_count"] == "0"
    assert "disruptions' delay" not in (tmp_path / "summary.md").read_text()


@pytest.mark.parametrize("command", ["simulate", "evaluate_strategies"])
def test_help_says_how_to_turn_disruptions_on_and_the_cost_off(command, capsys):
    import importlib

    module = importlib.import_module(f"training.commands.{command}")
    with pytest.raises(SystemExit):
        module.parse_args(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--case cmdp_pymunk/cases/precast_floor_disrupted.toml" in text
    assert "[disruptions]" in text and "docs/disruptions.md" in text
    assert "--no-disruption-cost" in text
