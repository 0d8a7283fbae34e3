"""Figs. 9-11 (media/charts.py), drawn from a hand-made event log on the tiny case.

The log below is a whole little run worked out by hand: X-1 cleans A then B and leaves;
K-1 waits for X-A, then hoists A (waiting for the crane first) and leaves; M-1 fetches bars,
reinforces C with one pause to fetch more, and is still walking out when the log ends at
540 s; M-2 never gets work and leaves at 540 s.
"""

from __future__ import annotations

import json

import imageio.v3 as iio
import numpy as np
import pytest

from cmdp_pymunk.events import Event, EventLog, write_atomic
from media import charts

# (time_s, kind, crew, subject)
RUN = [
    (0, "activity", "X-1", "navigating"),
    (0, "activity", "K-1", "idle_predecessor"),
    (0, "activity", "M-1", "idle_predecessor"),
    (0, "activity", "M-2", "idle_predecessor"),
    (0, "position", "X-1", "-6.00,3.00,0"),
    (0, "position", "K-1", "-6.00,-3.00,0"),
    (5, "position", "X-1", "-5.00,2.00,300"),
    (10, "task_start", "X-1", "X-A"),
    (10, "activity", "X-1", "tasking"),
    (130, "task_finish", "X-1", "X-A"),
    (130, "activity", "X-1", "navigating"),
    (130, "activity", "K-1", "navigating"),
    (135, "position", "X-1", "-1.00,1.00,0"),
    (135, "position", "K-1", "-5.00,-2.00,45"),
    (150, "position", "X-1", "3.00,0.50,0"),
    (160, "task_start", "X-1", "X-B"),
    (160, "activity", "X-1", "tasking"),
    (160, "task_start", "K-1", "K-A"),
    (160, "activity", "K-1", "waiting"),
    (220, "activity", "K-1", "tasking"),
    (280, "task_finish", "X-1", "X-B"),
    (280, "activity", "X-1", "deregistered"),
    (285, "position", "X-1", "-2.00,-2.00,180"),
    (290, "activity", "X-1", "left"),
    (300, "task_finish", "K-1", "K-A"),
    (300, "activity", "K-1", "deregistered"),
    (300, "activity", "M-1", "navigating"),
    (300, "activity", "M-2", "idle_no_target"),
    (305, "position", "M-1", "6.00,-1.00,90"),
    (320, "activity", "M-1", "fetching"),
    (350, "activity", "M-1", "navigating"),
    (370, "task_start", "M-1", "M-C"),
    (370, "activity", "M-1", "tasking"),
    (400, "task_pause", "M-1", "M-C"),
    (400, "activity", "M-1", "fetching"),
    (430, "activity", "M-1", "navigating"),
    (440, "task_resume", "M-1", "M-C"),
    (440, "activity", "M-1", "tasking"),
    (500, "task_finish", "M-1", "M-C"),
    (500, "activity", "M-1", "deregistered"),
    (500, "activity", "M-2", "deregistered"),
    (505, "position", "M-1", "2.00,-2.00,180"),
    (520, "activity", "K-1", "left"),
    (540, "activity", "M-2", "left"),
]

TASKING_RED = (214, 39, 40)  # #d62728, Fig. 9's tasking colour


def make_log(rows=RUN) -> EventLog:
    log = EventLog()
    for t, kind, crew, subject in rows:
        log.add(t, kind, crew, subject)
    return log


def make_events(rows=RUN) -> list[Event]:
    return make_log(rows).events


@pytest.fixture
def run_dir(tmp_path):
    write_atomic(tmp_path / "events.csv", make_log().to_csv())
    return tmp_path


def test_activity_intervals_by_hand():
    iv = charts.activity_intervals(make_events())
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
    iv = charts.activity_intervals(events, end_s=80)
    assert [tuple(i) for i in iv["A-1"]] == [(0, 80, "tasking")]
    assert [tuple(i) for i in iv["B-1"]] == [(50, 80, "navigating")]
    assert charts.activity_intervals([]) == {}


def test_task_bars_by_hand():
    bars = charts.task_bars(make_events())
    # Sorted by start; X-B and K-A both start at 160 and keep the log's order.
    assert [b.task for b in bars] == ["X-A", "X-B", "K-A", "M-C"]
    assert [b.crew for b in bars] == ["X-1", "X-1", "K-1", "M-1"]
    assert [b.segments for b in bars] == [((10, 130),), ((160, 280),), ((160, 300),),
                                          ((370, 400), (440, 500))]
    mc = bars[-1]
    assert mc.pauses == ((400, 440),)
    assert (mc.start_s, mc.end_s, mc.finished) == (370, 500, True)


def test_task_bars_of_a_log_cut_short():
    # M-C paused at 400 and the log ends at 420; X-A still running at the end.
    events = make_events([(0, "task_start", "X-1", "X-A"),
                          (370, "task_start", "M-1", "M-C"),
                          (400, "task_pause", "M-1", "M-C"),
                          (420, "activity", "M-1", "fetching")])
    bars = {b.task: b for b in charts.task_bars(events)}
    assert bars["X-A"].segments == ((0, 420),) and not bars["X-A"].finished
    assert bars["M-C"].segments == ((370, 400),) and not bars["M-C"].finished
    assert bars["M-C"].pauses == ()


def test_makespan_and_log_end():
    events = make_events()
    assert charts.makespan_s(events) == 500  # M-C's finish
    assert charts.log_end_s(events) == 540
    assert charts.makespan_s(make_events(RUN[:5])) is None


def test_crew_paths_and_execution_order(tiny_case):
    events = make_events()
    paths = charts.crew_paths(events)
    assert list(paths) == ["X-1", "K-1", "M-1"]
    np.testing.assert_array_equal(paths["X-1"], [[0, -6, 3], [5, -5, 2], [135, -1, 1],
                                                 [150, 3, 0.5], [285, -2, -2]])
    assert charts.execution_order(events, tiny_case, "X-1") == ["A", "B"]
    assert charts.execution_order(events, tiny_case, "M-1") == ["C"]  # resumed: counted once
    assert charts.execution_order(events, tiny_case, "M-2") == []
    assert charts.default_crew(tiny_case) == "X-1"  # no HIC in the tiny case: the first crew


def test_widths_grow_with_time():
    # times 0, 10, 30: segment midpoints 5 and 20, so fractions 5/30 and 20/30 of the span.
    w = charts.widths_by_time(np.array([0.0, 10.0, 30.0]), narrow=1.0, wide=4.0)
    np.testing.assert_allclose(w, [1.0 + 3.0 * 5 / 30, 1.0 + 3.0 * 20 / 30])
    assert charts.widths_by_time(np.array([7.0])).shape == (0,)


def test_task_types_from_case_or_prefix(tiny_case):
    assert charts.task_types(tiny_case, ["K-A", "Z-Q"]) == {"K-A": "K", "Z-Q": "Z"}
    assert charts.task_types(None, ["JC-P-11"]) == {"JC-P-11": "JC"}


def test_draw_run_writes_three_legible_pngs(run_dir, tiny_case):
    paths = charts.draw_run(run_dir, tiny_case)
    assert [p.name for p in paths] == ["gantt_agents.png", "gantt_tasks.png", "trajectories.png"]
    for p in paths:
        assert p.parent == run_dir
        image = iio.imread(p)
        assert image.ndim == 3 and image.shape[2] in (3, 4)
        assert image.shape[0] >= 250 and image.shape[1] >= 600, p.name
        assert len(np.unique(image[..., :3].reshape(-1, 3), axis=0)) > 20, p.name  # not blank
    agents = iio.imread(paths[0])[..., :3]
    assert np.all(agents == TASKING_RED, axis=-1).sum() > 100  # the tasking bars are drawn
    assert not list(run_dir.glob(".*.tmp"))  # written atomically: no temporary files left


def test_draw_run_refuses_a_log_of_another_case(run_dir):
    import cmdp_pymunk

    with pytest.raises(ValueError, match="X-A.*fix: pass the case"):
        charts.draw_run(run_dir, cmdp_pymunk.load_case())


def test_trajectories_rejects_an_unknown_crew(tiny_case, tmp_path):
    with pytest.raises(ValueError, match="one of X-1, K-1, M-1, M-2"):
        charts.trajectories(make_events(), tiny_case, tmp_path / "t.png", crew="HIC-1")


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
    path = charts.write_gif(iter(frames), tmp_path / "a.gif", 0.25)
    back = iio.imread(path, index=None)
    assert back.shape == (4, 12, 16, 3)
    assert iio.immeta(path, index=0)["duration"] == 250  # ms
    with pytest.raises(ValueError, match="frame 1"):
        charts.write_gif([frames[0], frames[1][..., :2]], tmp_path / "b.gif", 0.25)
    with pytest.raises(ValueError, match="no frames"):
        charts.write_gif([], tmp_path / "c.gif", 0.25)
