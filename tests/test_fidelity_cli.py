"""``--fidelity`` and ``--calibration`` of ``cmdp-simulate`` and ``cmdp-evaluate`` on the tiny
case: the event floor runs and says so in every record; the pymunk floor stays the default;
every option that cannot go with the event floor exits 2 with one line naming it and the fix,
before anything runs."""

from __future__ import annotations

import json
import shutil

import pytest

import cmdp_pymunk
from cmdp_pymunk.eventfloor.calibration import (
    Calibration,
    CrewTypeCalibration,
    fingerprint,
    write_calibration,
)
from training.commands import evaluate_strategies as compare
from training.commands import simulate

TINY = str(cmdp_pymunk.TINY_CASE)
QUIET = ["--no-progress", "--no-charts"]


def fitted(case, **numbers) -> Calibration:
    """A calibration of ``case`` as cmdp-calibrate would write it (numbers made up)."""
    crew_types = {name: CrewTypeCalibration(**numbers) for name in case.crew_types}
    return Calibration(case=case.case.name, fingerprint=fingerprint(case),
                       fitted_on="priority, seeds 0-19, pymunk floor (test)",
                       crew_types=crew_types)


def read(path) -> dict:
    return json.loads(path.read_text())


# -- cmdp-simulate ------------------------------------------------------------------------------

def test_simulate_runs_the_event_floor_and_records_it(tmp_path, capsys):
    out = tmp_path / "o"
    assert simulate.main(["--case", TINY, "--fidelity", "event", "--out", str(out),
                          "--seed", "3", *QUIET]) == 0
    captured = capsys.readouterr()
    header = captured.out.splitlines()[0]
    assert "event floor (uncalibrated, fingerprint" in header
    # uncalibrated: one line saying so and naming the command that calibrates
    assert captured.err.count("uncalibrated") == 1 and "cmdp-calibrate --case" in captured.err
    data = read(out / "summary.json")
    assert data["fidelity"] == "event" and data["all_finished"]
    tiny = cmdp_pymunk.load_case(TINY)
    assert data["calibration"]["file"] == "uncalibrated"
    assert data["calibration"]["fingerprint"] == fingerprint(tiny)
    for name in ("events.csv", "schedule.csv", "case.json"):
        assert (out / name).stat().st_size > 0
    # every task in the schedule, ended
    rows = (out / "schedule.csv").read_text().splitlines()[1:]
    assert len(rows) == len(tiny.tasks) and all(",end," in r for r in rows)


def test_the_default_floor_is_pymunk(tmp_path, capsys):
    assert simulate.parse_args([]).fidelity == "pymunk"
    assert compare.parse_args([]).fidelity == "pymunk"
    out = tmp_path / "o"
    assert simulate.main(["--case", TINY, "--out", str(out), *QUIET]) == 0
    captured = capsys.readouterr()
    assert "pymunk floor" in captured.out.splitlines()[0] and "uncalibrated" not in captured.err
    data = read(out / "summary.json")
    assert data["fidelity"] == "pymunk" and data["calibration"] is None


def test_episodes_on_the_event_floor_give_percentiles_histogram_and_s_curve(tmp_path, capsys):
    out = tmp_path / "o"
    assert simulate.main(["--case", TINY, "--fidelity", "event", "--out", str(out),
                          "--episodes", "4", "--workers", "1", "--no-progress",
                          "--no-seed-charts"]) == 0
    stats = read(out / "makespans.json")
    assert stats["fidelity"] == "event" and stats["calibration"]["file"] == "uncalibrated"
    assert stats["finished"] == 4 and stats["p50_s"] <= stats["p80_s"] <= stats["p90_s"]
    assert (out / "makespan_histogram.png").is_file() and (out / "s_curve.png").is_file()
    assert not (out / "seed-0" / "gantt_agents.png").exists()  # --no-seed-charts
    assert "4/4 episodes finished on the event floor" in capsys.readouterr().out


@pytest.mark.slow  # slow: the event floor's outputs are in the gate through the other tests here
def test_gantt_charts_and_gif_on_the_event_floor_without_trajectories(tmp_path, capsys):
    out = tmp_path / "o"
    assert simulate.main(["--case", TINY, "--fidelity", "event", "--out", str(out),
                          "--gif", "--no-progress"]) == 0
    assert (out / "gantt_agents.png").is_file() and (out / "gantt_tasks.png").is_file()
    assert (out / "rollout.gif").stat().st_size > 0
    assert not (out / "trajectories.png").exists()
    assert "no trajectories.png" in capsys.readouterr().out


def test_a_calibration_beside_the_case_is_used_and_recorded(tmp_path, capsys):
    case_file = tmp_path / "tiny_floor.toml"
    shutil.copy(TINY, case_file)
    case = cmdp_pymunk.load_case(case_file)
    written = write_calibration(fitted(case, walk_factor=1.3, task_invasion=0.05),
                                tmp_path / "tiny_floor.event.toml")
    out = tmp_path / "o"
    assert simulate.main(["--case", str(case_file), "--fidelity", "event", "--out", str(out),
                          *QUIET]) == 0
    captured = capsys.readouterr()
    assert f"calibration {written}" in captured.out.splitlines()[0]
    assert "uncalibrated" not in captured.err
    record = read(out / "summary.json")["calibration"]
    assert record["file"] == str(written) and record["fingerprint"] == fingerprint(case)
    assert record["crew_types"]["RC"]["walk_factor"] == 1.3


def test_an_explicit_calibration_is_used(tmp_path):
    case = cmdp_pymunk.load_case(TINY)
    path = write_calibration(fitted(case, walk_factor=2.0), tmp_path / "mine.event.toml")
    out = tmp_path / "o"
    assert simulate.main(["--case", TINY, "--fidelity", "event", "--calibration", str(path),
                          "--out", str(out), *QUIET]) == 0
    assert read(out / "summary.json")["calibration"]["file"] == str(path)


# -- what cannot go with the event floor: exit 2, one line, before anything runs ---------------

def other_floor_calibration(tmp_path):
    builtin = cmdp_pymunk.load_case(None)
    return write_calibration(fitted(builtin), tmp_path / "precast.event.toml")


def bad_toml(tmp_path):
    path = tmp_path / "bad.event.toml"
    path.write_text("[event_floor\nwalk = ")
    return path


@pytest.mark.parametrize("options, words", [
    (["--calibration", "x.event.toml"], ["--calibration", "--fidelity event"]),
    (["--fidelity", "event", "--navigator", "models/stage1_reaching.zip"],
     ["--fidelity event", "--navigator models/stage1_reaching.zip", "no", "fix"]),
    (["--fidelity", "event", "--calibration", "{other}"],
     ["--calibration", "another floor", "cmdp-calibrate"]),
    (["--fidelity", "event", "--calibration", "{bad}"], ["--calibration", "TOML", "fix"]),
    (["--fidelity", "event", "--calibration", "{missing}"], ["--calibration", "cannot read"]),
    (["--fidelity", "fast"], ["--fidelity", "invalid choice", "'fast'"]),
])
def test_simulate_refuses_what_the_event_floor_cannot_run(tmp_path, capsys, options, words):
    paths = {"{other}": str(other_floor_calibration(tmp_path)), "{bad}": str(bad_toml(tmp_path)),
             "{missing}": str(tmp_path / "none.event.toml")}
    out = tmp_path / "o"
    argv = ["--case", TINY, "--out", str(out), *QUIET, *(paths.get(o, o) for o in options)]
    try:
        code = simulate.main(argv)
    except SystemExit as stop:  # argparse's choices
        code = stop.code
    assert code == 2
    err = capsys.readouterr().err
    assert all(w in err for w in words), err
    assert not out.exists()  # nothing ran, nothing written


def test_a_bad_calibration_beside_the_case_names_it(tmp_path, capsys):
    case_file = tmp_path / "tiny_floor.toml"
    shutil.copy(TINY, case_file)
    (tmp_path / "tiny_floor.event.toml").write_text("[event_floor]\ncase = 3\n")
    assert simulate.main(["--case", str(case_file), "--fidelity", "event",
                          "--out", str(tmp_path / "o"), *QUIET]) == 2
    err = capsys.readouterr().err
    assert "tiny_floor.event.toml" in err and "--calibration" in err and "fix" in err


# -- cmdp-evaluate ------------------------------------------------------------------------------

def test_evaluate_runs_the_event_floor_and_records_it(tmp_path, capsys):
    out = tmp_path / "e"
    assert compare.main(["--case", TINY, "--fidelity", "event", "--seeds", "0-2",
                         "--workers", "1", "--out", str(out), "--no-progress"]) == 0
    captured = capsys.readouterr()
    assert "on the event floor (uncalibrated" in captured.out
    assert captured.err.count("uncalibrated") == 1
    summary = read(out / "summary.json")
    assert {e["fidelity"] for e in summary} == {"event"}
    assert {e["calibration"] for e in summary} == {"uncalibrated"}
    assert (out / "summary.md").read_text().startswith("On the event floor")
    settings = read(out / "settings.json")
    assert settings["fidelity"] == "event" and settings["calibration"]["file"] == "uncalibrated"
    rows = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    assert len(rows) == 6 and {r["fidelity"] for r in rows} == {"event"}
    assert all(r["finished"] for r in rows)
    assert (out / "time_use.csv").is_file()
    for name in ("makespan_histogram.png", "s_curve.png", "fig12_makespan.png"):
        assert (out / name).is_file()
    assert "fidelity" in (out / "episodes.csv").read_text().splitlines()[0]


def test_evaluate_resumes_only_on_the_floor_it_started_on(tmp_path, capsys):
    out = tmp_path / "e"
    argv = ["--case", TINY, "--seeds", "0", "--strategies", "priority", "--workers", "1",
            "--out", str(out), "--no-progress", "--no-figures"]
    assert compare.main([*argv, "--fidelity", "event"]) == 0
    capsys.readouterr()
    assert compare.main([*argv, "--resume"]) == 2
    assert "fidelity" in capsys.readouterr().err


@pytest.mark.parametrize("options, words", [
    (["--calibration", "x.event.toml"], ["--calibration", "--fidelity event"]),
    (["--fidelity", "event", "--navigators", "scripted,models/stage1_reaching.zip"],
     ["--fidelity event", "--navigators models/stage1_reaching.zip", "fix"]),
    (["--fidelity", "event", "--calibration", "{other}"], ["--calibration", "another floor"]),
])
def test_evaluate_refuses_what_the_event_floor_cannot_run(tmp_path, capsys, options, words):
    paths = {"{other}": str(other_floor_calibration(tmp_path))}
    out = tmp_path / "e"
    assert compare.main(["--case", TINY, "--seeds", "0", "--out", str(out), "--no-progress",
                         *(paths.get(o, o) for o in options)]) == 2
    err = capsys.readouterr().err
    assert all(w in err for w in words), err
    assert not out.exists()


def test_a_run_from_before_the_option_resumes_as_a_pymunk_run(tmp_path, capsys):
    out = tmp_path / "e"
    argv = ["--case", TINY, "--seeds", "0", "--strategies", "priority", "--workers", "1",
            "--out", str(out), "--no-progress", "--no-figures"]
    assert compare.main(argv) == 0
    saved = read(out / "resume.json")
    del saved["fidelity"], saved["calibration"]  # as written before --fidelity
    (out / "resume.json").write_text(json.dumps(saved))
    assert compare.main([*argv, "--resume"]) == 0


def test_the_workers_get_the_floor(tmp_path):
    """The runner's arguments carry the fidelity and the calibration to worker processes and
    Ray actors (``training.runs.base.make_runner``): they pickle."""
    import pickle

    from training.fidelity import resolve_floor
    from training.runs.base import make_runner

    case = cmdp_pymunk.load_case(TINY)
    path = write_calibration(fitted(case, walk_factor=1.5), tmp_path / "c.event.toml")
    floor = resolve_floor(case, None, "event", path, {"--navigator": ["scripted"]})
    runner = make_runner(pickle.loads(pickle.dumps((case, 3600.0, None, False, None,
                                                    *floor.runner_args))))
    engine, _ = runner.play("priority", "scripted", 0)
    assert engine.motion.name == "event" and engine.motion.calibration.of("RC").walk_factor == 1.5
