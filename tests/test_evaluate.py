"""``cmdp-evaluate`` and its statistics (training/runs/paired.py), on the tiny example case."""

import argparse
import csv
import json
import re
from pathlib import Path

import pytest

import cmdp_pymunk
from agents.task_priority import save_priorities
from cmdp_pymunk.bounds import lower_bound
from training.cli import seed_list, seeds_text
from training.commands import evaluate_strategies as evaluate
from training.runs.paired import mean_ci, paired
from training.runs.strategies import read_log

TINY = str(cmdp_pymunk.TINY_CASE)
FILES = ("episodes.jsonl", "episodes.csv", "summary.csv", "summary.md", "summary.json",
         "settings.json", "resume.json", "cpsat_plan.json", "fig12_makespan.png",
         "fig13_reaching_steps.png", "fig14_idle_task_area.png", "makespan_histogram.png",
         "s_curve.png")
DOCS = Path(__file__).resolve().parents[1] / "docs" / "comparing.md"


def documented_outputs() -> set[str]:
    """Every file named in the first column of docs/comparing.md's "What cmdp-evaluate writes"
    table."""
    text = DOCS.read_text().split("## What `cmdp-evaluate` writes", 1)[1]
    names = set()
    for line in text.splitlines():
        if line.startswith("| `"):
            names |= set(re.findall(r"`([\w.-]+\.\w+)`", line.split("|")[1]))
    return names


def test_seed_list():
    assert seed_list("0-3") == [0, 1, 2, 3]
    assert seed_list("5,0-1,9") == [5, 0, 1, 9]
    for bad in ("3-1", "a", "-1", "1,1"):
        with pytest.raises(argparse.ArgumentTypeError):
            seed_list(bad)


def test_seeds_text_is_read_back_by_seed_list():
    # a run of seeds as a range, anything else as a list, and seed_list reads either back
    assert seeds_text([0, 1, 2, 3]) == "0-3"
    assert seeds_text([5, 0, 1, 9]) == "5,0,1,9"
    assert seeds_text([7]) == "7-7"
    for seeds in ([0, 1, 2, 3], [5, 0, 1, 9], [100, 101], [3]):
        assert seed_list(seeds_text(seeds)) == seeds


def test_mean_ci_by_hand():
    # 1, 2, 3: mean 2, sample std 1, t(0.975, 2) = 4.3027 -> 4.3027 / sqrt(3) = 2.4841
    mean, std, ci = mean_ci([1.0, 2.0, 3.0])
    assert (mean, std) == (2.0, 1.0) and ci == pytest.approx(2.4841, abs=1e-4)
    assert mean_ci([5.0]) == (5.0, None, None) and mean_ci([None]) == (None, None, None)


def test_summary_has_the_planners_percentiles():
    from training.runs.paired import markdown_table, summarize

    rows = [{"strategy": "priority", "navigator": "scripted", "seed": s, "finished": True,
             "makespan_s": m, "stalled": False, "timed_out": False}
            for s, m in enumerate((100.0, 200.0, 300.0, 400.0, 500.0))]
    e = summarize(rows, 50.0, None)[0]
    # five values, rank q/100 * 4 from 0: P50 rank 2 -> 300; P80 rank 3.2 -> 400 + 0.2 * 100
    # = 420; P90 rank 3.6 -> 400 + 0.6 * 100 = 460
    assert (e["makespan_p50_s"], e["makespan_p80_s"], e["makespan_p90_s"]) == \
        pytest.approx((300.0, 420.0, 460.0))
    assert "| 300 / 420 / 460 |" in markdown_table([e], 50.0, None)


def test_summary_over_the_seed_bound_is_the_mean_of_per_seed_ratios():
    from training.runs.paired import markdown_table, summarize

    rows = [{"strategy": "priority", "navigator": "scripted", "seed": s, "finished": f,
             "makespan_s": m, "stalled": False, "timed_out": not f, "seed_bound_s": b}
            for s, m, b, f in ((0, 150.0, 100.0, True), (1, 300.0, 150.0, True),
                               (2, None, 120.0, False))]
    e = summarize(rows, 50.0, None)[0]
    # bounds 100, 150, 120: mean 123.33; finished ratios 1.5 and 2.0: mean 1.75 (the unfinished
    # seed has no ratio); the ratio of means would be 225 / 125 = 1.8
    assert e["seed_bound_mean_s"] == pytest.approx(370.0 / 3)
    assert e["over_seed_bound"] == pytest.approx(1.75)
    table = markdown_table([e], 50.0, None)
    assert "| 4.50 | 1.75 | - |" in table and "Seed bound" in table


def test_paired_difference_over_common_finished_seeds():
    ref = [{"seed": s, "finished": True, "makespan_s": m} for s, m in ((0, 100), (1, 200),
                                                                       (2, 300))]
    mine = [{"seed": 0, "finished": True, "makespan_s": 90},
            {"seed": 1, "finished": True, "makespan_s": 170},
            {"seed": 2, "finished": False, "makespan_s": None}]
    out = paired(mine, ref)
    # seeds 0 and 1: differences -10 and -30 -> mean -20; ratio (90 + 170) / (100 + 200)
    assert out["paired_seeds"] == 2 and out["diff_mean_s"] == -20.0
    assert out["ratio"] == pytest.approx(260 / 300)


def test_evaluate_writes_every_file(tmp_path, capsys):
    case = cmdp_pymunk.load_case(TINY)
    ga = save_priorities(tmp_path / "ga.json", case, {t.id: 0.5 for t in case.tasks}, 0.5, "ga")
    out = tmp_path / "cmp"
    assert evaluate.main(["--case", TINY, "--seeds", "0-1", "--strategies",
                          f"priority,nearest,ga:{ga},cpsat", "--workers", "1", "--out",
                          str(out), "--cpsat-s", "5", "--no-progress"]) == 0
    for name in FILES:
        assert (out / name).stat().st_size > 0, name
    documented = documented_outputs()
    assert "s_curve.png" in documented and "episodes.jsonl" in documented
    assert documented <= set(FILES), "docs/comparing.md names a file no test checks"
    rows = list(csv.DictReader((out / "episodes.csv").open()))
    assert len(rows) == 8 and {r["strategy"] for r in rows} == {"priority", "nearest",
                                                                f"ga:{ga}", "cpsat"}
    assert all(r["finished"] == "True" and float(r["makespan_s"]) > 0 for r in rows)
    summary = json.loads((out / "summary.json").read_text())
    prio = summary[0]
    assert prio["strategy"] == "priority" and prio["vs_priority_ratio"] == 1.0
    settings = json.loads((out / "settings.json").read_text())
    assert settings["cpsat"]["optimal"] and settings["seeds"] == [0, 1]
    assert "| priority | scripted | 2/2 |" in (out / "summary.md").read_text()
    # the seed bound (issue 32): per episode in episodes.jsonl and the CSV's last column, its
    # mean and the mean of makespan / it per strategy in the summary
    from cmdp_pymunk.bounds import seed_lower_bound

    bounds = {s: seed_lower_bound(case, s).seed_bound_s for s in (0, 1)}
    jsonl = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    assert all(r["seed_bound_s"] == pytest.approx(bounds[r["seed"]], abs=1e-3) for r in jsonl)
    # appended after it: the floor the episode ran on (--fidelity; tests/test_fidelity_cli.py)
    assert list(rows[0])[-5:-3] == ["seed_bound_s", "fidelity"]
    # then what each episode cost (docs/levers.md; tests/test_whatif.py)
    assert list(rows[0])[-3:] == ["crane_lifts", "cost", "cost_crew_rates_x2"]
    assert {r["fidelity"] for r in rows} == {"pymunk"}
    assert prio["seed_bound_mean_s"] == pytest.approx((bounds[0] + bounds[1]) / 2, abs=1e-3)
    mine = [r for r in jsonl if r["strategy"] == "priority"]
    assert prio["over_seed_bound"] == pytest.approx(
        sum(r["makespan_s"] / r["seed_bound_s"] for r in mine) / 2)
    assert "x seed bound" in (out / "summary.md").read_text()
    printed = capsys.readouterr().out
    assert "CP-SAT schedule bound" in printed
    # announced with its time limit before it runs, and before its answer
    assert printed.index("solving CP-SAT for the cpsat strategy, time limit 5 s") < \
        printed.index("CP-SAT bound")


def hand_percentile(values: list[float], q: float) -> float:
    """q-th percentile, linear between order statistics: rank q/100 * (n - 1) from 0."""
    x = sorted(values)
    rank = q / 100 * (len(x) - 1)
    lo = int(rank)
    return x[lo] + (rank - lo) * (x[min(lo + 1, len(x) - 1)] - x[lo])


def test_histogram_and_s_curve_inputs_match_the_episodes(tmp_path):
    """The makespan histogram's P50/P80/P90 (summary.json) are the percentiles of the
    episodes' makespans, worked out here by hand; the S-curve's input, each episode's task
    end times, ends at its makespan and counts its tasks. With a calendar starting Friday
    2026-01-09 15:30 (08:00-16:00 Mon-Fri, the 12th a holiday) each finish and each
    percentile gets its date: by hand, second s > 1800 is Tue 13th 08:00 + (s - 1800)."""
    import datetime as dt

    out = tmp_path / "cmp"
    assert evaluate.main(["--case", TINY, "--seeds", "0-2", "--strategies", "priority",
                          "--workers", "1", "--out", str(out), "--no-progress",
                          "--start", "2026-01-09T15:30", "--holidays", "2026-01-12"]) == 0
    for name in ("makespan_histogram.png", "s_curve.png"):
        assert (out / name).stat().st_size > 1000, name
    rows = read_log(out / "episodes.jsonl")
    makespans = [r["makespan_s"] for r in rows]
    assert len(makespans) == 3 and len(set(makespans)) > 1  # three seeds, not all alike
    entry = json.loads((out / "summary.json").read_text())[0]
    # three values a <= b <= c: P50 rank 1 -> b; P80 rank 1.6 -> b + 0.6 (c - b);
    # P90 rank 1.8 -> b + 0.8 (c - b)
    a, b, c = sorted(makespans)
    assert entry["makespan_p50_s"] == pytest.approx(b) == hand_percentile(makespans, 50)
    assert entry["makespan_p80_s"] == pytest.approx(b + 0.6 * (c - b))
    assert entry["makespan_p90_s"] == pytest.approx(b + 0.8 * (c - b))

    def by_hand(s: float) -> str:
        assert 1800 < s <= 1800 + 28800  # the tiny floor ends on Tuesday
        at = dt.datetime(2026, 1, 13, 8) + dt.timedelta(seconds=s - 1800)
        return at.replace(microsecond=0).isoformat()

    assert [entry[f"finish_{k}"] for k in ("mean", "p50", "p80", "p90")] == [by_hand(
        entry[f"makespan_{k}_s"]) for k in ("mean", "p50", "p80", "p90")]
    finishes = {int(r["seed"]): r["finish"]  # by name: the cost columns follow it
                for r in csv.DictReader((out / "episodes.csv").open())}
    assert finishes == {r["seed"]: by_hand(r["makespan_s"]) for r in rows}
    assert f"| priority | scripted | {by_hand(entry['makespan_mean_s']).replace('T', ' ')}" in \
        (out / "summary.md").read_text()
    n_tasks = len(cmdp_pymunk.load_case(TINY).tasks)
    for r in rows:
        ends = r["task_end_times_s"]
        assert len(ends) == r["tasks_finished"] == n_tasks and ends == sorted(ends)
        assert ends[-1] == r["makespan_s"] and ends[0] > 0
    # the list stays in episodes.jsonl: episodes.csv keeps one number per cell
    assert "task_end_times_s" not in (out / "episodes.csv").read_text().splitlines()[0]


def test_cpsat_is_solved_only_when_asked_for(tmp_path, capsys, monkeypatch):
    """The default strategies solve no CP-SAT; the bound columns fall back on the lower bound
    and say so; --cpsat-bound solves it for its bound alone (no plan replayed)."""
    import agents.cpsat

    calls = []
    real = agents.cpsat.solve
    monkeypatch.setattr(agents.cpsat, "solve", lambda *a: calls.append(a) or real(*a))
    assert "cpsat" not in evaluate.parse_args([]).strategies
    out = tmp_path / "plain"
    assert evaluate.main(["--case", TINY, "--seeds", "0", "--workers", "1", "--out", str(out),
                          "--no-progress", "--no-figures"]) == 0
    assert calls == []
    printed = capsys.readouterr().out
    assert "solving CP-SAT" not in printed and "CP-SAT not solved" in printed
    summary = json.loads((out / "summary.json").read_text())
    assert [e["strategy"] for e in summary] == ["priority", "nearest"]
    lb = lower_bound(cmdp_pymunk.load_case(TINY)).lower_bound_s
    for e in summary:
        assert e["over_lower_bound"] == pytest.approx(e["makespan_mean_s"] / lb)
        assert e["over_cpsat_bound"] is None
    assert "CP-SAT schedule bound: not solved" in (out / "summary.md").read_text()
    assert json.loads((out / "settings.json").read_text())["cpsat"] is None
    assert not (out / "cpsat_plan.json").exists()

    out = tmp_path / "bound"
    assert evaluate.main(["--case", TINY, "--seeds", "0", "--strategies", "priority",
                          "--cpsat-bound", "--cpsat-s", "5", "--workers", "1", "--out",
                          str(out), "--no-progress", "--no-figures"]) == 0
    assert len(calls) == 1 and "solving CP-SAT (--cpsat-bound), time limit 5 s" in \
        capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    bound = json.loads((out / "settings.json").read_text())["cpsat"]["bound_s"]
    assert summary[0]["over_cpsat_bound"] == pytest.approx(summary[0]["makespan_mean_s"] / bound)
    assert not (out / "cpsat_plan.json").exists()


def test_a_stalled_strategy_is_reported(tmp_path, capsys):
    out = tmp_path / "stall"
    # no task moves on in the first 5 s of walking: every episode stalls
    assert evaluate.main(["--case", TINY, "--seeds", "0-1", "--strategies", "priority",
                          "--workers", "1", "--out", str(out), "--stall-s", "5",
                          "--cpsat-s", "5", "--no-progress", "--no-figures"]) == 1
    summary = json.loads((out / "summary.json").read_text())[0]
    assert summary["stalled"] == 2 and summary["stalled_seeds"] == [0, 1]
    assert summary["finished"] == 0 and summary["makespan_mean_s"] is None
    assert "priority / scripted: stalled on seed(s) 0, 1." in (out / "summary.md").read_text()
    rows = list(csv.DictReader((out / "episodes.csv").open()))
    assert all(r["stalled"] == "True" and "no task moved on" in r["stall_reason"]
               for r in rows)


def test_bad_strategy_fails_before_any_episode(tmp_path, capsys):
    assert evaluate.main(["--case", TINY, "--strategies", "priority,nope.zip", "--out",
                          str(tmp_path / "x"), "--no-progress"]) == 2
    assert "no such model file" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("option, typo, fix", [("--strategies", "priorty", "priority"),
                                               ("--navigators", "scriptd", "scripted")])
def test_a_misspelt_name_is_blamed_on_our_option_with_the_closest_name(tmp_path, capsys,
                                                                       option, typo, fix):
    assert evaluate.main(["--case", TINY, option, typo, "--out", str(tmp_path / "x"),
                          "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert f"cmdp-evaluate: {option} {typo!r}: no such model file; did you mean {fix!r}?" in err
    assert not (tmp_path / "x").exists()


@pytest.mark.slow
def test_two_workers_give_the_same_episodes(tmp_path):
    outs = []
    for w in ("1", "2"):
        out = tmp_path / w
        assert evaluate.main(["--case", TINY, "--seeds", "0-3", "--strategies",
                              "priority,nearest", "--workers", w, "--out", str(out),
                              "--cpsat-s", "5", "--no-progress", "--no-figures"]) == 0
        rows = list(csv.DictReader((out / "episodes.csv").open()))
        # episodes.jsonl is in the order they finish: compare it by episode
        ends = {(r["strategy"], r["seed"]): r["task_end_times_s"]
                for r in read_log(out / "episodes.jsonl")}
        outs.append(([{k: v for k, v in r.items() if k != "wall_s"} for r in rows], ends))
    assert outs[0] == outs[1]


@pytest.mark.slow
def test_a_stage2_model_is_a_strategy(tmp_path):
    """An (untrained) stage-2 model .zip goes through evaluator_from_spec like any strategy."""
    from stable_baselines3 import PPO

    from training.stage2 import Stage2Config, make_decision_loop, training_case
    from training.vec_env import FloorsVecEnv

    config = Stage2Config(case=TINY, central_critic=False)
    venv = FloorsVecEnv([lambda: make_decision_loop(config, training_case(config))])
    model = PPO("MlpPolicy", venv, n_steps=8, batch_size=8,
                policy_kwargs={"net_arch": [8]}, device="cpu", seed=0)
    path = tmp_path / "stage2.zip"
    model.save(path)
    out = tmp_path / "cmp"
    code = evaluate.main(["--case", TINY, "--seeds", "0", "--strategies", f"priority,{path}",
                          "--workers", "1", "--out", str(out), "--cpsat-s", "5",
                          "--no-progress", "--no-figures"])
    rows = list(csv.DictReader((out / "episodes.csv").open()))
    assert [r["strategy"] for r in rows] == ["priority", str(path)]
    assert code == (0 if all(r["finished"] == "True" for r in rows) else 1)
