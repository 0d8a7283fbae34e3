"""``cmdp-simulate`` in-process through ``main([...])``, on the tiny example case."""

import contextlib
import io
import json

import pytest

import cmdp_pymunk
from training.commands import simulate

TINY = str(cmdp_pymunk.TINY_CASE)


def test_simulate_writes_summary_events_and_charts(tmp_path, capsys):
    out = tmp_path / "run"
    assert simulate.main(["--case", TINY, "--out", str(out), "--seed", "3", "--no-progress"]) == 0
    data = json.loads((out / "summary.json").read_text())
    assert data["all_finished"] and data["tasks_finished"] == data["tasks_total"] == 3
    assert data["makespan_s"] > data["lower_bound"]["lower_bound_s"] > 0
    assert data["makespan_over_lower_bound"] == pytest.approx(
        data["makespan_s"] / data["lower_bound"]["lower_bound_s"])
    # the bound on seed 3's own floor (issue 32): what bounds.seed_lower_bound says, never beaten
    from cmdp_pymunk.bounds import seed_lower_bound

    bound = seed_lower_bound(cmdp_pymunk.load_case(TINY), 3)
    assert data["seed_bound_s"] == pytest.approx(bound.seed_bound_s)
    assert data["seed_bound_binding"] == bound.binding
    assert data["makespan_over_seed_bound"] == pytest.approx(
        data["makespan_s"] / bound.seed_bound_s) and data["makespan_over_seed_bound"] >= 1.0
    crew = data["crews"]["RC-1"]
    assert set(crew["idle_steps"]) == {"waiting_for_predecessor", "blocked_by_task_area",
                                       "no_target"}
    assert crew["idle_steps"]["waiting_for_predecessor"] > 0  # R waits for HI
    assert crew["material_trips"] >= 1 and crew["distance_m"] > 0
    assert data["seed"] == 3 and data["versions"]["pymunk"]
    events = (out / "events.csv").read_text().splitlines()
    assert events[0] == "time_s,kind,crew,subject,detail,x_m,y_m,heading_deg"
    assert sum(",task_finish," in e for e in events) == 3
    for chart in ("gantt_agents.png", "gantt_tasks.png", "trajectories.png"):
        assert (out / chart).stat().st_size > 1000
    assert json.loads((out / "case.json").read_text())["case"]["name"] == "tiny"
    assert "makespan" in capsys.readouterr().out


def test_same_seed_same_schedule(tmp_path):
    for name in ("a", "b"):
        assert simulate.main(["--case", TINY, "--out", str(tmp_path / name), "--no-charts",
                              "--no-progress"]) == 0
    assert (tmp_path / "a" / "events.csv").read_text() == \
        (tmp_path / "b" / "events.csv").read_text()


def test_episodes_table(tmp_path):
    out = tmp_path / "many"
    assert simulate.main(["--case", TINY, "--out", str(out), "--episodes", "3", "--no-charts",
                          "--no-progress"]) == 0
    stats = json.loads((out / "makespans.json").read_text())
    assert stats["episodes"] == stats["finished"] == 3
    assert stats["min_s"] <= stats["mean_s"] <= stats["max_s"]
    assert stats["min_s"] <= stats["p50_s"] <= stats["p80_s"] <= stats["p90_s"] <= stats["max_s"]
    assert len((out / "makespans.csv").read_text().splitlines()) == 4
    assert (out / "seed-1" / "summary.json").exists()
    assert not (out / "s_curve.png").exists()  # --no-charts


@pytest.fixture(scope="module")
def charted_run(tmp_path_factory):
    """One run of 3 episodes with every chart and the GIF, and what it printed (stdout,
    stderr): the tests of its files read it instead of each simulating and drawing its own
    (issue 43: the gate's time)."""
    out = tmp_path_factory.mktemp("simulate") / "charts"
    printed, errors = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(errors):
        code = simulate.main(["--case", TINY, "--out", str(out), "--episodes", "3", "--gif",
                              "--no-progress"])
    assert code == 0
    return out, printed.getvalue(), errors.getvalue()


def test_schedule_csv_per_seed(charted_run):
    out = charted_run[0]
    for seed in (0, 1):
        header, *rows = (out / f"seed-{seed}" / "schedule.csv").read_text().splitlines()
        assert header == ("task,crew,start_s,end_s,pauses,paused_s,finished,task_type,"
                          "component,status,duration_s")
        cells = [r.split(",") for r in rows]
        assert sorted(c[0] for c in cells) == ["HI-P-1", "R-J-1", "R-J-2"]  # the tiny case's tasks
        assert all(c[6] == "true" and float(c[2]) < float(c[3]) for c in cells)
        assert all(c[9] == "end" and float(c[10]) == float(c[3]) - float(c[2]) for c in cells)
        assert [c[7:9] for c in cells if c[0] == "HI-P-1"] == [["HI", "P-1"]]
        summary = json.loads((out / f"seed-{seed}" / "summary.json").read_text())
        assert max(float(c[3]) for c in cells) == summary["makespan_s"]


def test_episodes_write_percentiles_histogram_and_s_curve(charted_run):
    out, printed_out, printed_err = charted_run
    for name in ("makespan_histogram.png", "s_curve.png"):
        assert (out / name).stat().st_size > 1000
    assert (out / "seed-2" / "gantt_tasks.png").exists()
    stats = json.loads((out / "makespans.json").read_text())
    assert f"P80 {stats['p80_s']:.0f} s" in printed_out
    # 3 floors: P80/P90 flagged in the file and on the console
    assert "from 3 finished floors (fewer than 20)" in stats["percentiles_note"]
    assert "warning: P80/P90 from 3 finished floors" in printed_err


def documented_files(heading: str) -> list[list[str]]:
    """The files named in the first column of each ``| file | what |`` table under ``heading``
    in docs/simulating.md, one list per table (other tables, such as schedule.csv's columns,
    are left out)."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "simulating.md").read_text()
    section = text.split(heading, 1)[1].split("\n## ", 1)[0]
    tables, rows, files = [], [], False
    for line in section.splitlines() + [""]:
        if line.startswith("|"):
            files = files or line.startswith("| file |")
            if files and line.startswith("| `"):
                rows.append(re.findall(r"`([\w.-]+\.\w+)`", line.split("|")[1])[0])
        else:
            if rows:
                tables.append(rows)
            rows, files = [], False
    return tables


def test_every_documented_file_is_written(charted_run):
    """docs/simulating.md's "What it writes": the first table per seed (case.json in the run
    folder), the second in the run folder of --episodes N (the shared run: 3 episodes, every
    chart, --gif)."""
    per_seed, per_run = documented_files("## What it writes")
    assert "schedule.csv" in per_seed and "s_curve.png" in per_run
    out = charted_run[0]
    for name in per_seed:
        assert (out / "seed-0" / name).is_file() or (out / name).is_file(), name
    for name in per_run:
        assert (out / name).is_file(), name


def test_gif_is_written(tmp_path):
    out = tmp_path / "gif"
    assert simulate.main(["--case", TINY, "--out", str(out), "--gif", "--no-charts",
                          "--no-progress"]) == 0
    import imageio.v3 as iio

    from training.runs.seed_outputs import GIF_FPS, GIF_SECONDS

    frames = iio.imread(out / "rollout.gif", index=None)
    assert 2 <= len(frames) <= GIF_SECONDS * GIF_FPS


def test_a_ctrl_c_while_the_gif_streams_leaves_no_half_gif(tmp_path, monkeypatch, capsys):
    """The frames go to a temporary file as they are drawn: a Ctrl-C mid-episode deletes it."""
    from media.gif import GifStream

    real = GifStream.append

    def append(self, frame):
        if self.frames == 3:
            raise KeyboardInterrupt
        real(self, frame)

    monkeypatch.setattr(GifStream, "append", append)
    out = tmp_path / "gif"
    assert simulate.main(["--case", TINY, "--out", str(out), "--gif", "--no-charts",
                          "--no-progress"]) == 130
    assert sorted(p.name for p in out.iterdir()) == ["case.json"]
    assert "interrupted in seed 0" in capsys.readouterr().err


class Frozen:
    """A low level that never moves anyone: nobody reaches anything."""

    reads_rays = False

    def reset(self, seed):
        pass

    def bind(self, engine):
        pass

    def actions(self, engine, observations=None):
        from cmdp_pymunk.move import STAND_STILL

        return [STAND_STILL] * len(engine.site.crews)


@pytest.fixture
def gantt_figures(monkeypatch):
    """The Gantt figures cmdp-simulate draws, by function name (their texts are checked, not
    their pixels)."""
    from media import gantt

    drawn = {}

    def spying(name):
        real = getattr(gantt, name)

        def spy(*args, **kwargs):
            drawn[name] = real(*args, **kwargs)
            return drawn[name]
        return spy

    for name in ("gantt_agents_figure", "gantt_tasks_figure"):
        monkeypatch.setattr(gantt, name, spying(name))
    return drawn


def figure_texts(fig) -> list[str]:
    from matplotlib.text import Text

    return [t.get_text() for t in fig.findobj(Text) if t.get_text()]


def schedule_rows(folder) -> dict[str, dict]:
    import csv

    with open(folder / "schedule.csv", newline="") as f:
        return {r["task"]: r for r in csv.DictReader(f)}


def test_stall_is_detected_and_reported(tmp_path, capsys, monkeypatch, gantt_figures):
    import agents.specs

    monkeypatch.setattr(agents.specs, "Navigator", Frozen)
    out = tmp_path / "stall"
    assert simulate.main(["--case", TINY, "--out", str(out), "--stall-s", "200",
                          "--no-progress"]) == 1
    data = json.loads((out / "summary.json").read_text())
    assert data["stalled"]["after_s"] >= 200 and not data["all_finished"]
    # the env's own stall guard (the one training uses) stopped it: at 200 s, not later
    assert data["simulated_s"] == data["stalled"]["time_s"] == 200
    assert {c["crew"] for c in data["stalled"]["crews"]} == {"HIC-1", "RC-1"}
    # the console says it in prose (no JSON), naming the crew and the target it walks to, and
    # the floor at the stall is drawn beside summary.json, which keeps the report as data
    err = capsys.readouterr().err
    assert "STALLED" in err and "At t = 200 s no task had moved on for 200 s" in err
    assert "HIC-1 (HIC, " in err and "walks to task HI-P-1's work point at P-1" in err
    assert '"crews"' not in err
    assert (out / "stall.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(out.glob(".*.tmp"))  # written atomically: no temporary file left
    # schedule.csv lists every task although none started, in the case's order: HI-P-1 has no
    # predecessor (queue), both R tasks wait for it; no crew, no times
    assert (out / "schedule.csv").read_text().splitlines()[1:] == [
        "HI-P-1,,,,0,0,false,HI,P-1,queue,", "R-J-1,,,,0,0,false,R,J-1,wait,",
        "R-J-2,,,,0,0,false,R,J-2,wait,"]
    # the charts say where it stopped (200 s = 0.056 h) and how far it got, not a makespan
    label = "stalled at t = 0.06 h (200 s), 0 of 3 tasks ended"
    assert gantt_figures["gantt_tasks_figure"].axes[0].get_title() == f"Tasks: tiny\n{label}"
    for fig in gantt_figures.values():
        texts = figure_texts(fig)
        assert label in texts and not [t for t in texts if "makespan" in t]


def test_a_run_that_stalls_midway_lists_every_task_and_its_state(tmp_path, monkeypatch,
                                                                 gantt_figures):
    """The scripted low level until the first task_pause (on seed 0, RC-1 leaves R-J-2 to
    fetch bars), then nobody moves: HI-P-1 and R-J-1 ended, R-J-2 on and paused until the
    stall, 200 s after its pause (the last progress)."""
    import agents.specs
    from agents.navigator import Navigator

    class FreezesAtFirstPause(Navigator):
        def actions(self, engine, observations=None):
            if any(e.kind == "task_pause" for e in engine.log.events):
                return Frozen().actions(engine)
            return super().actions(engine, observations)

    monkeypatch.setattr(agents.specs, "Navigator", FreezesAtFirstPause)
    out = tmp_path / "midway"
    assert simulate.main(["--case", TINY, "--out", str(out), "--stall-s", "200",
                          "--no-progress"]) == 1
    data = json.loads((out / "summary.json").read_text())
    events = (out / "events.csv").read_text().splitlines()
    pause = [float(e.split(",")[0]) for e in events if ",task_pause," in e]
    stop = data["simulated_s"]
    assert data["stalled"] and len(pause) == 1 and stop == pause[0] + 200
    rows = schedule_rows(out)
    assert list(rows) == ["HI-P-1", "R-J-1", "R-J-2"]  # by start
    assert [(r["status"], r["finished"], r["crew"]) for r in rows.values()] == [
        ("end", "true", "HIC-1"), ("end", "true", "RC-1"), ("on", "false", "RC-1")]
    for r in rows.values():
        if r["status"] == "end":
            assert float(r["duration_s"]) == float(r["end_s"]) - float(r["start_s"]) > 0
    rj2 = rows["R-J-2"]
    assert (rj2["end_s"], rj2["duration_s"], rj2["pauses"]) == ("", "", "1")
    assert float(rj2["paused_s"]) == stop - pause[0] == 200  # the open pause, up to the stop
    label = f"stalled at t = {stop / 3600:.2f} h ({stop:.0f} s), 2 of 3 tasks ended"
    for fig in gantt_figures.values():
        assert fig.axes[0].get_title().endswith(f"\n{label}")
        assert not [t for t in figure_texts(fig) if "makespan" in t]


def test_a_run_cut_by_the_time_limit_says_so(tmp_path, gantt_figures):
    out = tmp_path / "limit"
    assert simulate.main(["--case", TINY, "--out", str(out), "--max-time-s", "1000",
                          "--no-progress"]) == 1
    data = json.loads((out / "summary.json").read_text())
    assert not data["all_finished"] and not data["stalled"] and data["simulated_s"] == 1000
    n = data["tasks_finished"]
    assert 0 < n < 3  # HI-P-1 ends near 800 s on seed 0, the R tasks need longer
    label = f"time limit at t = 0.28 h (1000 s), {n} of 3 tasks ended"
    assert gantt_figures["gantt_tasks_figure"].axes[0].get_title() == f"Tasks: tiny\n{label}"
    rows = schedule_rows(out)
    assert len(rows) == 3 and sum(r["status"] == "end" for r in rows.values()) == n
    assert all(r["end_s"] == "" for r in rows.values() if r["status"] != "end")


def test_bad_input_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[plane]\nwidth_m = -1\n")
    assert simulate.main(["--case", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "bad.toml" in err and "Traceback" not in err
    assert simulate.main(["--case", TINY, "--navigator", str(tmp_path / "nope.zip"),
                          "--out", str(tmp_path / "o")]) == 2
    assert "no such model file" in capsys.readouterr().err


def test_no_charts_says_so(tmp_path, capsys):
    from cmdp_pymunk import TINY_CASE
    from training.commands.simulate import main

    assert main(["--case", str(TINY_CASE), "--out", str(tmp_path), "--no-charts",
                 "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[-1].startswith("cmdp-simulate: summary, schedule.csv and events.csv in")
    assert not (tmp_path / "gantt_tasks.png").exists()


def seed_files(out, seeds) -> dict:
    """Each seed's events.csv, schedule.csv and summary.json without the wall times (the only
    numbers that differ between two runs of the same seeds), and makespans.csv."""
    files = {"makespans.csv": (out / "makespans.csv").read_text()}
    for seed in seeds:
        folder = out / f"seed-{seed}"
        data = json.loads((folder / "summary.json").read_text())
        for key in ("wall_s", "simulated_s_per_wall_s"):
            data.pop(key)
        files[seed] = ((folder / "events.csv").read_text(),
                       (folder / "schedule.csv").read_text(), data)
    return files


@pytest.mark.slow  # slow: two worker processes start (test_backends keeps the gate's sample of it)
def test_episodes_are_the_same_with_any_number_of_workers(tmp_path, capsys):
    """Seeds 4-6 in this process, in 2 worker processes, and with the GIF's seed rendered here
    and the others in the workers: the same files."""
    argv = ["--case", TINY, "--seed", "4", "--episodes", "3", "--no-charts", "--no-progress"]
    runs = {"one": [], "two": ["--workers", "2"], "gif": ["--workers", "2", "--gif"]}
    for name, extra in runs.items():
        assert simulate.main([*argv, *extra, "--out", str(tmp_path / name)]) == 0
    files = {name: seed_files(tmp_path / name, (4, 5, 6)) for name in runs}
    assert files["one"] == files["two"] == files["gif"]
    assert "3 episodes, 2 worker process(es)" in capsys.readouterr().out
    assert (tmp_path / "gif" / "seed-4" / "rollout.gif").exists()


def test_a_calendar_dates_the_schedule_across_a_weekend_and_a_holiday(tmp_path, capsys):
    """Second 0 is Fri 2026-01-09 15:30, days 08:00-16:00 Mon-Fri, Mon 12th a holiday: by
    hand, second s <= 1800 is Fri 15:30 + s, and a later one (within a day) Tue 13th 08:00 +
    (s - 1800). The tiny floor takes longer than Friday's half hour, so its dates cross the
    weekend and the holiday."""
    import datetime as dt

    out = tmp_path / "run"
    assert simulate.main(["--case", TINY, "--out", str(out), "--seed", "3", "--no-progress",
                          "--no-charts", "--start", "2026-01-09T15:30",
                          "--holidays", "2026-01-12"]) == 0

    def by_hand(seconds: str) -> str:
        s = float(seconds)
        assert s <= 1800 + 28800  # within Tuesday, as this rule assumes
        at = dt.datetime(2026, 1, 9, 15, 30) + dt.timedelta(seconds=s) if s <= 1800 else \
            dt.datetime(2026, 1, 13, 8) + dt.timedelta(seconds=s - 1800)
        return at.isoformat(timespec="seconds")

    lines = (out / "schedule.csv").read_text().splitlines()
    assert lines[0] == ("task,crew,start_s,end_s,pauses,paused_s,finished,task_type,"
                        "component,status,duration_s,start,end")
    rows = [line.split(",") for line in lines[1:]]
    assert len(rows) == 3
    for row in rows:
        assert (row[11], row[12]) == (by_hand(row[2]), by_hand(row[3]))
    data = json.loads((out / "summary.json").read_text())
    assert data["makespan_s"] > 1800  # the run does cross the weekend
    assert data["calendar"]["finish"] == by_hand(data["makespan_s"])
    assert data["calendar"]["finish"].startswith("2026-01-13T")
    assert (data["calendar"]["second_0"], data["calendar"]["start_moved"]) == \
        ("2026-01-09T15:30:00", False)
    assert json.loads((out / "case.json").read_text())["calendar"]["holidays"] == ["2026-01-12"]
    printed = capsys.readouterr().out
    assert "calendar 08:00-16:00 Mon-Fri, 1 holiday, second 0 = Fri 2026-01-09 15:30" in printed
    assert f"finish {by_hand(data['makespan_s']).replace('T', ' ')[:16]}" in printed


def test_a_calendar_file_and_a_start_outside_working_time(tmp_path, capsys):
    site = tmp_path / "site.toml"
    site.write_text('[calendar]\nstart = 2026-01-10T10:00:00\nworking_hours = "07:00-15:00"\n',
                    encoding="utf-8")
    out = tmp_path / "run"
    assert simulate.main(["--case", TINY, "--out", str(out), "--no-progress", "--no-charts",
                          "--calendar", str(site)]) == 0
    data = json.loads((out / "summary.json").read_text())["calendar"]
    # Saturday 10:00 is not working time: second 0 is Monday 07:00
    assert (data["second_0"], data["start_moved"]) == ("2026-01-12T07:00:00", True)
    assert "(the start Sat 2026-01-10 10:00 is not working time: moved to the next working " \
           "moment)" in capsys.readouterr().out


def test_without_a_calendar_the_outputs_are_as_before(tmp_path):
    out = tmp_path / "run"
    assert simulate.main(["--case", TINY, "--out", str(out), "--no-progress",
                          "--no-charts"]) == 0
    assert (out / "schedule.csv").read_text().splitlines()[0].endswith(",status,duration_s")
    assert "calendar" not in json.loads((out / "summary.json").read_text())
    assert "calendar" not in json.loads((out / "case.json").read_text())


@pytest.mark.parametrize("options, words", [
    (["--working-hours", "16:00-08:00"], "command line: --working-hours: "
                                         '"16:00-08:00" ends before it starts'),
    (["--start", "2026-01-09", "--working-days", "Mon-Fry"],
     'command line: --working-days: "Fry" is not a weekday; fix: did you mean "Fri"?'),
    (["--start", "2026-02-30T08:00"], 'command line: --start: "2026-02-30T08:00" is not a '
                                      "date and time; fix:"),
    (["--start", "2026-01-09T08:00", "--holidays", "2026-01-12,12/01/2026"],
     'command line: --holidays: "12/01/2026" is not a date; fix: write YYYY-MM-DD'),
    (["--start", "2026-01-09T08:00", "--ifc-start", "2026-01-09T08:00:00"],
     "command line: --ifc-start: a working calendar gives the 4D export its dates"),
    (["--calendar", "nowhere.toml"], "nowhere.toml: cannot read the file"),
])
def test_a_bad_calendar_option_exits_2_before_anything_runs(tmp_path, capsys, options, words):
    out = tmp_path / "o"
    assert simulate.main(["--case", TINY, "--out", str(out), *options]) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err and ("fix:" in err)
    assert not out.exists()
