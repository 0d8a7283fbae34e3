"""Figs. 9-11 (media/gantt.py, media/layout_views.py; the log read by media/timeline.py), the
GIF writer (media/gif.py) and a run folder's charts (media/charts.py), drawn from the hand-made
event log of ``conftest.RUN`` on the tiny case."""

from __future__ import annotations

import json

import imageio.v3 as iio
import numpy as np
import pytest
from conftest import RUN, distinct_colours, make_events, make_log

from cmdp_pymunk.events import Event, write_atomic
from media import charts, figures, gantt, gif, layout_views, timeline

TASKING_RED = (214, 39, 40)  # #d62728, Fig. 9's tasking colour


@pytest.fixture
def run_dir(tmp_path):
    write_atomic(tmp_path / "events.csv", make_log().to_csv())
    return tmp_path


def test_activity_intervals_by_hand():
    iv = timeline.activity_intervals(make_events())
    assert list(iv) == ["X-1", "K-1", "M-1", "M-2"]  # the order crews first appear
    as_tuples = {crew: [tuple(i) for i in ivs] for crew, ivs in iv.items()}
    # X-1 leaves at 290: nothing after it.
    assert as_tuples["X-1"] == [(0, 10, "navigating"), (10, 130, "tasking"),
                                (130, 160, "navigating"), (160, 280, "tasking"),
                                (280, 290, "deregistered")]
    assert as_tuples["K-1"] == [(0, 130, "idle_predecessor"), (130, 160, "navigating"),
                                (160, 220, "waiting"), (220, 300, "tasking"),
                                (300, 520, "deregistered")]
    # M-1 never logs "left": its last interval runs to the log's end, 540 s.
    assert as_tuples["M-1"] == [(0, 300, "idle_predecessor"), (300, 320, "navigating"),
                                (320, 350, "fetching"), (350, 370, "navigating"),
                                (370, 400, "tasking"), (400, 430, "fetching"),
                                (430, 440, "navigating"), (440, 500, "tasking"),
                                (500, 540, "deregistered")]
    assert as_tuples["M-2"] == [(0, 300, "idle_predecessor"), (300, 500, "idle_no_target"),
                                (500, 540, "deregistered")]


def test_activity_intervals_end_at_the_given_time_and_drop_empty_ones():
    events = make_events([(0, "activity", "A-1", "navigating"),
                          (0, "activity", "A-1", "tasking"),  # replaces the first at once
                          (50, "activity", "B-1", "navigating")])
    iv = timeline.activity_intervals(events, end_s=80)
    assert [tuple(i) for i in iv["A-1"]] == [(0, 80, "tasking")]
    assert [tuple(i) for i in iv["B-1"]] == [(50, 80, "navigating")]
    assert timeline.activity_intervals([]) == {}


def test_crew_paths_and_execution_order(tiny_case):
    events = make_events()
    paths = timeline.crew_paths(events)
    assert list(paths) == ["X-1", "K-1", "M-1"]
    np.testing.assert_array_equal(paths["X-1"], [[0, -6, 3], [5, -5, 2], [135, -1, 1],
                                                 [150, 3, 0.5], [285, -2, -2]])
    assert timeline.execution_order(events, tiny_case, "X-1") == ["A", "B"]
    assert timeline.execution_order(events, tiny_case, "M-1") == ["C"]  # resumed: counted once
    assert timeline.execution_order(events, tiny_case, "M-2") == []
    assert layout_views.default_crew(tiny_case) == "X-1"  # no HIC in the tiny case: the first crew


def test_widths_grow_with_time():
    # times 0, 10, 30: segment midpoints 5 and 20, so fractions 5/30 and 20/30 of the span.
    w = layout_views.widths_by_time(np.array([0.0, 10.0, 30.0]), narrow=1.0, wide=4.0)
    np.testing.assert_allclose(w, [1.0 + 3.0 * 5 / 30, 1.0 + 3.0 * 20 / 30])
    assert layout_views.widths_by_time(np.array([7.0])).shape == (0,)


def test_task_types_from_case_or_prefix(tiny_case):
    assert timeline.task_types(tiny_case, ["K-A", "Z-Q"]) == {"K-A": "K", "Z-Q": "Z"}
    assert timeline.task_types(None, ["JC-P-11"]) == {"JC-P-11": "JC"}


def test_draw_run_writes_three_legible_pngs(run_dir, tiny_case):
    paths = charts.draw_run(run_dir, tiny_case)
    assert [p.name for p in paths] == ["gantt_agents.png", "gantt_tasks.png",
                                       "resource_profile.png", "trajectories.png"]
    for p in paths:
        assert p.parent == run_dir
        image = iio.imread(p)
        assert image.ndim == 3 and image.shape[2] in (3, 4)
        assert image.shape[0] >= 250 and image.shape[1] >= 600, p.name
        assert distinct_colours(image) > 20, p.name  # not blank
    agents = iio.imread(paths[0])[..., :3]
    assert np.all(agents == TASKING_RED, axis=-1).sum() > 100  # the tasking bars are drawn
    assert not list(run_dir.glob(".*.tmp"))  # written atomically: no temporary files left


def test_draw_run_refuses_a_log_of_another_case(run_dir):
    import cmdp_pymunk

    with pytest.raises(ValueError, match="X-A.*fix: pass the case"):
        charts.draw_run(run_dir, cmdp_pymunk.load_case())


def test_trajectories_rejects_an_unknown_crew(tiny_case, tmp_path):
    with pytest.raises(ValueError, match="one of X-1, K-1, M-1, M-2"):
        layout_views.trajectories(make_events(), tiny_case, tmp_path / "t.png", crew="HIC-1")


def test_cli(tmp_path, capsys):
    assert charts.main([str(tmp_path)]) == 2
    assert "events.csv does not exist" in capsys.readouterr().err
    # A two-task run on the built-in case (no --case: the built-in one).
    rows = [(0, "activity", "JCC-1", "navigating"), (0, "position", "JCC-1", "-24.5,-9,0"),
            (5, "position", "JCC-1", "-20,-8,10"), (8, "task_start", "JCC-1", "JC-P-31"),
            (8, "activity", "JCC-1", "tasking"), (700, "task_finish", "JCC-1", "JC-P-31"),
            (700, "activity", "JCC-1", "left")]
    write_atomic(tmp_path / "events.csv", make_log(rows).to_csv())
    assert charts.main([str(tmp_path)]) == 0
    assert "trajectories.png" in capsys.readouterr().out
    assert (tmp_path / "gantt_tasks.png").is_file()


def test_cli_finds_the_resolved_case_json(tmp_path, tiny_case, capsys):
    """cmdp-simulate saves case.json beside the run, or above its seed-K/ folders."""
    write_atomic(tmp_path / "case.json", json.dumps(tiny_case.model_dump(mode="json")))
    write_atomic(tmp_path / "seed-0" / "events.csv", make_log().to_csv())
    assert charts.main([str(tmp_path / "seed-0")]) == 0
    assert (tmp_path / "seed-0" / "trajectories.png").is_file()
    write_atomic(tmp_path / "case.json", "{not json")
    assert charts.main([str(tmp_path / "seed-0")]) == 2
    assert "case.json" in capsys.readouterr().err


def test_write_gif(tmp_path):
    frames = [np.full((12, 16, 3), 40 * i, dtype=np.uint8) for i in range(4)]
    path = gif.write_gif(iter(frames), tmp_path / "a.gif", 0.25)
    back = iio.imread(path, index=None)
    assert back.shape == (4, 12, 16, 3)
    assert iio.immeta(path, index=0)["duration"] == 250  # ms
    with pytest.raises(ValueError, match="frame 1"):
        gif.write_gif([frames[0], frames[1][..., :2]], tmp_path / "b.gif", 0.25)
    with pytest.raises(ValueError, match="no frames"):
        gif.write_gif([], tmp_path / "c.gif", 0.25)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif"]  # no temporary left


def test_gif_stream_merges_repeats_and_stores_changed_rectangles(tmp_path):
    """Frames come back pixel for pixel; a repeated frame lengthens the one before; only the
    changed rectangle of a frame is stored (the file holds a 2 x 3 image for frame 2)."""
    from PIL import Image

    a = np.zeros((10, 14, 3), np.uint8)
    b = a.copy()
    b[4:6, 7:10] = (200, 30, 30)
    c = b.copy()
    c[0, 0] = (1, 2, 3)
    with gif.GifStream(tmp_path / "s.gif", 0.1) as stream:
        for frame in (a, a, a, b, c):
            stream.append(frame)
    assert (stream.frames, stream.stored) == (5, 3)
    back = iio.imread(tmp_path / "s.gif", index=None)
    assert back.shape == (3, 10, 14, 3)
    for got, want in zip(back, (a, b, c), strict=True):
        assert np.array_equal(got, want)
    with Image.open(tmp_path / "s.gif") as im:
        durations, tiles = [], []
        for i in range(im.n_frames):
            im.seek(i)
            durations.append(im.info["duration"])
            tiles.append(im.tile[0][1] if im.tile else None)
    assert durations == [300, 100, 100]
    assert tiles[1] == (7, 4, 10, 6)  # x0, y0, x1, y1 of the red patch


def test_gif_stream_leaves_nothing_when_interrupted(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        with gif.GifStream(tmp_path / "x.gif", 0.1) as stream:
            stream.append(np.zeros((4, 4, 3), np.uint8))
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_every_crew_gets_its_own_small_panel(tiny_case):
    """Fig. 11 (b): one panel per crew with a path, titled with its id, in the given order."""
    from matplotlib.figure import Figure

    paths = {"RC-1": np.array([[0.0, -1.0, 0.0], [5.0, 1.0, 0.5], [9.0, 2.0, 1.0]]),
             "HIC-1": np.array([[0.0, 2.0, 2.0], [4.0, 2.0, -1.0]])}
    axes = layout_views.crew_multiples(Figure(), paths, tiny_case, ["HIC-1", "RC-1"])
    assert [ax.get_title() for ax in axes] == ["HIC-1", "RC-1"]
    segments = [len(c.get_segments()) for ax in axes for c in ax.collections
                if isinstance(c, layout_views.LineCollection)]
    assert segments == [1, 2]  # a path of k points is k - 1 segments


def chart_texts(fig) -> list[str]:
    """Every text a figure shows: titles, tick labels, legend entries."""
    from matplotlib.text import Text

    return [t.get_text() for t in fig.findobj(Text) if t.get_text()]


# conftest.RUN cut at 400 s: X-A, X-B and K-A ended; M-C on, paused at 400.
CUT = [r for r in RUN if r[0] <= 400]


def test_run_end_by_hand():
    events = make_events()
    # finished: the makespan is M-C's finish, 500 s = 0.139 h
    end = timeline.run_end(events, 4)
    assert end == timeline.RunEnd("finished", 500, 4, 4) and end.finished
    assert end.label() == "makespan 0.14 h (500 s)"
    assert timeline.run_end(events, 4, {"all_finished": True, "stalled": None,
                                        "simulated_s": 500.0}) == end
    cut = make_events(CUT)
    # summary.json says it stalled at 720 s (after the log's last event, 400 s): 0.2 h
    stalled = timeline.run_end(cut, 4, {"all_finished": False, "simulated_s": 720.0,
                                        "stalled": {"time_s": 720.0, "after_s": 320.0}})
    assert stalled == timeline.RunEnd("stalled", 720, 3, 4) and not stalled.finished
    assert stalled.label() == "stalled at t = 0.20 h (720 s), 3 of 4 tasks ended"
    limit = timeline.run_end(cut, 4, {"all_finished": False, "stalled": None, "simulated_s": 900})
    assert limit.label() == "time limit at t = 0.25 h (900 s), 3 of 4 tasks ended"
    # no summary.json (or one without the keys): the log and the case's count alone
    for summary in (None, {"case": "tiny"}):
        assert timeline.run_end(cut, 4, summary).label() == \
            "unfinished at t = 0.11 h (400 s), 3 of 4 tasks ended"
    # a log that reads as finished by count, with no summary: the makespan
    assert timeline.run_end(cut, 3).label() == "makespan 0.08 h (300 s)"


def test_a_stalled_run_s_gantt_charts_say_so_instead_of_a_makespan(tiny_case):
    cut = make_events(CUT)
    end = timeline.RunEnd("stalled", 720.0, 3, 4)
    label = "stalled at t = 0.20 h (720 s), 3 of 4 tasks ended"
    tasks = gantt.gantt_tasks_figure(cut, tiny_case, "Tasks: tiny", end)
    agents = gantt.gantt_agents_figure(cut, "Crews' activities: tiny", end)
    assert tasks.axes[0].get_title() == f"Tasks: tiny\n{label}"
    assert agents.axes[0].get_title() == f"Crews' activities: tiny\n{label}"
    for fig in (tasks, agents):
        texts = chart_texts(fig)
        assert label in texts  # the legend's entry for the dotted line at 720 s
        assert not [t for t in texts if "makespan" in t]
        line = [ln for ln in fig.axes[0].lines if ln.get_label() == label]
        assert len(line) == 1 and line[0].get_xdata()[0] == pytest.approx(0.2)
        assert fig.axes[0].get_xlim()[1] >= 0.2  # the axis reaches the stop
    assert tasks.axes[0].get_ylabel() == "4 tasks, by start time"
    # M-C, paused at 400 and never resumed, is drawn paused up to the stop: 400-720 s
    paused = [c for c in tasks.axes[0].collections if c.get_alpha() == 0.25]
    assert [p.get_paths()[0].get_extents().x1 * 3600 for p in paused] == pytest.approx([720])
    # without ``end``, the tasks chart judges by the case: 3 of its 4 tasks ended
    texts = chart_texts(gantt.gantt_tasks_figure(cut, tiny_case))
    assert "unfinished at t = 0.11 h (400 s), 3 of 4 tasks ended" in texts


def test_a_run_that_started_few_tasks_says_how_many(tiny_case):
    # the log ends at 160 s (0.044 h): X-A ended, X-B and K-A just started, M-C not
    events = make_events([r for r in CUT if r[0] <= 160])
    fig = gantt.gantt_tasks_figure(events, tiny_case, end=timeline.run_end(events, 4))
    assert fig.axes[0].get_ylabel() == "3 of 4 tasks started, by start time"
    assert fig.axes[0].get_title() == \
        "Tasks (Fig. 10)\nunfinished at t = 0.04 h (160 s), 1 of 4 tasks ended"


def test_a_finished_run_s_gantt_charts_still_say_makespan(tiny_case):
    events = make_events()
    for fig in (gantt.gantt_tasks_figure(events, tiny_case, "Tasks: tiny"),
                gantt.gantt_agents_figure(events, "Crews' activities: tiny",
                                          timeline.run_end(events, 4))):
        assert fig.axes[0].get_title() in ("Tasks: tiny", "Crews' activities: tiny")
        texts = chart_texts(fig)
        assert "makespan 0.14 h (500 s)" in texts
        assert not [t for t in texts if "stalled" in t or "unfinished" in t]
    # no case, no end (an old caller): the last finish is the makespan, as before
    assert "makespan 0.14 h (500 s)" in chart_texts(gantt.gantt_agents_figure(events))


def test_draw_run_reads_how_the_run_ended_from_summary_json(run_dir, tiny_case, monkeypatch):
    write_atomic(run_dir / "events.csv", make_log(CUT).to_csv())
    write_atomic(run_dir / "summary.json", json.dumps(
        {"all_finished": False, "stalled": {"time_s": 720.0}, "simulated_s": 720.0}))
    drawn = []
    real = gantt.gantt_tasks_figure
    monkeypatch.setattr(gantt, "gantt_tasks_figure",
                        lambda *a, **k: drawn.append(real(*a, **k)) or drawn[-1])
    assert charts.main([str(run_dir), "--case", str(run_dir / "case.json")]) == 2  # no such
    write_atomic(run_dir / "case.json", json.dumps(tiny_case.model_dump(mode="json")))
    assert charts.main([str(run_dir)]) == 0
    assert drawn[-1].axes[0].get_title() == \
        "Tasks: tiny\nstalled at t = 0.20 h (720 s), 3 of 4 tasks ended"
    (run_dir / "summary.json").unlink()  # an old or partial run folder: the log and the case
    assert charts.main([str(run_dir)]) == 0
    assert drawn[-1].axes[0].get_title() == \
        "Tasks: tiny\nunfinished at t = 0.11 h (400 s), 3 of 4 tasks ended"


def test_with_a_calendar_the_gantt_charts_get_a_date_axis(tiny_case):
    """Second 0 is Fri 2026-01-09 15:55, days 08:00-16:00 Mon-Fri, Mon 12th a holiday: the log
    runs to 540 s, so Tuesday opens on the axis at 300 s = 0.0833 h; the makespan, 500 s, is
    200 s into Tuesday, 08:03."""
    from cmdp_pymunk.cases.model import Calendar

    calendar = Calendar(start="2026-01-09T15:55", holidays=["2026-01-12"])
    case = tiny_case.model_copy(update={"calendar": calendar})
    events = make_events()
    assert figures.date_ticks(calendar, 540) == [(0.0, "Fri 09 Jan 15:55"),
                                                (pytest.approx(300 / 3600), "Tue 13 Jan")]
    for fig in (gantt.gantt_tasks_figure(events, case, "Tasks: tiny"),
                gantt.gantt_agents_figure(events, "Crews' activities: tiny",
                                          timeline.run_end(events, 4), calendar)):
        ax = fig.axes[0]
        top = ax.child_axes[0]
        assert [t.get_text() for t in top.get_xticklabels()] == ["Fri 09 Jan 15:55",
                                                                 "Tue 13 Jan"]
        assert top.get_xlabel() == ("date (second 0: Fri 2026-01-09 15:55; working "
                                    "08:00-16:00 Mon-Fri, 1 holiday)")
        assert ax.get_xlabel() == "simulated working time (h)"
        assert "makespan 0.14 h (500 s), Tue 2026-01-13 08:03" in chart_texts(fig)
    # over many working days every k-th opening is labelled: 40 days -> every 4th
    ticks = figures.date_ticks(calendar, 300 + 39 * 28800)
    assert len(ticks) == 11 and ticks[1][1] == "Fri 16 Jan"  # Tue, Wed, Thu, [Fri]
    # without a calendar: no date axis, as before
    assert gantt.gantt_tasks_figure(events, tiny_case).axes[0].child_axes == []


def test_s_curve_title_says_how_many_episodes_finished():
    from media.episodes import s_curve_title

    assert s_curve_title([[1, 2, 3], [1, 2, 3]], 3) == "Tasks ended over time (S-curve)"
    assert s_curve_title([[1, 2, 3], [1], []], 3) == \
        "Tasks ended over time (S-curve): 1 of 3 episodes finished; P50/P80/P90 over those"
    assert s_curve_title([[1]], 3, percentiles=False) == \
        "Tasks ended over time (S-curve): 0 of 1 episodes finished"


def test_stall_picture_draws_a_hand_made_stall_report(tmp_path, tiny_case):
    """The floor at a stall from a report and the hand-made log (``conftest.RUN``): a walking
    crew with its target and planned way, a parked one; written atomically as a PNG."""
    report = {"after_s": 200.0, "time_s": 540.0, "tasks_on": [], "tasks_queued": ["M-C"],
              "crews": [
                  {"crew": "M-1", "radius_m": 0.56, "activity": "navigating",
                   "position_m": [2.0, -2.0], "heading_for": {
                       "target": "C", "task": "M-C", "position_m": [0.5, 0.0],
                       "distance_m": 2.5}, "way_m": [[2.0, -2.0], [1.5, -1.5], [1.0, -1.0]]},
                  {"crew": "M-2", "radius_m": 0.56, "activity": "idle_no_target",
                   "position_m": [6.0, 3.0], "heading_for": None}]}
    path = layout_views.stall_picture(report, tiny_case, tmp_path / "stall.png", make_events())
    assert path.read_bytes()[:4] == b"\x89PNG" and not list(tmp_path.glob(".*.tmp"))


# conftest.RUN with the crane's two lifts: K-1's hoisting assist lands at 220 s (the tiny
# case's assist_time_s 30 s: the crane busy 190-220) and M-1's material at 360 s (lift_time_s
# 60 s: busy 300-360).
CRANE = [Event(220.0, "crane_done", "K-1", "K-A", "task"),
         Event(360.0, "crane_done", "M-1", "S", "material")]


def test_crews_busy_counted_by_hand():
    """Busy = tasking, fetching or waiting for the crane (the intervals of
    test_activity_intervals_by_hand): X-1 (XC) tasks 10-130 and 160-280; K-1 (KC) waits
    160-220 then tasks 220-300, busy throughout 160-300; M-1 (MC) fetches 320-350, tasks
    370-400, fetches 400-430, tasks 440-500; M-2 (MC) is never busy. The count changes at
    each of those times (a switch between two busy activities, at 220 and 400, changes
    nothing); 0 is always a step."""
    crew_types = {"X-1": "XC", "K-1": "KC", "M-1": "MC", "M-2": "MC"}
    profile = timeline.crews_busy(make_events(), crew_types)
    times = [0, 10, 130, 160, 220, 280, 300, 320, 350, 370, 400, 430, 440, 500]
    assert profile.times_s.tolist() == times
    assert list(profile.counts) == ["XC", "KC", "MC"]
    by_time = {k: dict(zip(times, v.tolist(), strict=True)) for k, v in profile.counts.items()}
    assert [t for t in times if by_time["XC"][t]] == [10, 160, 220]  # on [10,130), [160,280)
    assert [t for t in times if by_time["KC"][t]] == [160, 220, 280]  # on [160, 300)
    assert [t for t in times if by_time["MC"][t]] == [320, 370, 400, 440]
    assert max(max(v.values()) for v in by_time.values()) == 1 and profile.crews == \
        {"XC": 1, "KC": 1, "MC": 2}


def test_crane_lifts_and_busy_share_per_bin_by_hand():
    """Bins of 200 s up to 540 s: [0, 200), [200, 400), [400, 600). Both lifts land in the
    second bin; the assist's 30 s (190-220) puts 10 s in the first bin and 20 s in the
    second, the material lift's 60 s (300-360) all in the second: shares 10/200, 80/200, 0."""
    lifts = timeline.crane_lifts(make_events() + CRANE)
    assert lifts == [(220.0, "task"), (360.0, "material")]
    starts, count, busy = timeline.crane_per_bin(lifts, {"material": 60.0, "task": 30.0}, 540.0,
                                                 bin_s=200.0)
    assert starts.tolist() == [0, 200, 400]
    assert {k: v.tolist() for k, v in count.items()} == {"material": [0, 1, 0],
                                                         "task": [0, 1, 0]}
    assert busy.tolist() == pytest.approx([0.05, 0.4, 0.0])
    # a lift landing on a bin's edge counts in the later bin; its time before it in the earlier
    _, count, busy = timeline.crane_per_bin([(400.0, "material")], {"material": 60.0}, 540.0,
                                            bin_s=200.0)
    assert count["material"].tolist() == [0, 0, 1]
    assert busy.tolist() == pytest.approx([0.0, 0.3, 0.0])


def test_resource_profile_chart(tmp_path, tiny_case):
    fig = gantt.resource_profile_figure(make_events() + CRANE, tiny_case)
    texts = chart_texts(fig)
    assert "MC: rebar crew (2 crews)" in texts and "XC: cleaning crew (1 crew)" in texts
    assert "material lifts" in texts and "hoisting assists" in texts
    assert "crane lifts\nper 15 min" in texts  # a run under 4 h: bins of 15 minutes
    assert "makespan 0.14 h (500 s)" in texts
    path = gantt.resource_profile(make_events() + CRANE, tiny_case, tmp_path / "r.png")
    image = iio.imread(path)
    assert image.shape[1] >= 600 and distinct_colours(image) > 20


# -- the split of media/charts.py (issue 43): readers apart from plotting, old names kept ------

def test_the_log_readers_import_no_plotting_library():
    """media/timeline.py reads the event log into intervals: a report or a script that asks
    what a crew did when must not need matplotlib (or pygame, or Pillow) for it."""
    import ast
    from pathlib import Path

    tree = ast.parse(Path(timeline.__file__).read_text(encoding="utf-8"))
    names = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    names |= {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    tops = {n.split(".")[0] for n in names}
    assert not tops & {"matplotlib", "pygame", "PIL", "media"}, tops
    assert tops <= {"__future__", "collections", "typing", "numpy", "cmdp_pymunk"}, tops


def test_media_charts_still_offers_the_names_it_documented():
    """The docs, the examples and the changelog named these ``media.charts.X``: each is still
    there, and is the moved object itself, not a copy that could drift."""
    moved = {"GifStream": gif, "write_gif": gif, "RunEnd": timeline, "run_end": timeline,
             "activity_intervals": timeline, "gantt_agents": gantt,
             "gantt_agents_figure": gantt, "gantt_tasks": gantt, "gantt_tasks_figure": gantt,
             "resource_profile": gantt, "resource_profile_figure": gantt,
             "trajectories": layout_views, "stall_picture": layout_views}
    assert set(moved) <= set(charts.__all__)
    for name, module in moved.items():
        assert getattr(charts, name) is getattr(module, name), name
        assert getattr(module, name).__module__ == module.__name__, name
