"""Charts of many episodes (media/episodes.py), from hand-made makespans and finish times, and
Fig. 10's task ids (media/gantt.py) on a log of more tasks than fit an unlabelled axis."""

import imageio.v3 as iio
from conftest import make_events

from cmdp_pymunk.report import makespan_stats
from media import gantt
from media.episodes import draw_episodes

# three episodes of 4 tasks; the third stops after 2
FINISHES = [[130, 280, 300, 500], [100, 200, 420, 610], [150, 400]]
ROWS = [{"makespan_s": 500.0, "reach_rate": 1.0}, {"makespan_s": 610.0, "reach_rate": 1.0},
        {"makespan_s": None, "reach_rate": 1.0}]


def test_histogram_and_s_curve_are_drawn(tmp_path):
    stats = makespan_stats(ROWS)
    assert stats["p50_s"] == 555.0  # halfway between the two finished, 500 and 610
    hist, curve = draw_episodes(tmp_path, stats, FINISHES, total_tasks=4)
    assert hist.name == "makespan_histogram.png" and curve.name == "s_curve.png"
    for png in (hist, curve):
        image = iio.imread(png)
        assert image.shape[0] > 300 and image.shape[1] > 500
        assert len(set(map(tuple, image[::7, ::7, :3].reshape(-1, 3)))) > 4  # not blank


def test_no_finished_episode_still_draws(tmp_path):
    stats = makespan_stats([{"makespan_s": None, "reach_rate": 0.0}])
    assert stats["p90_s"] is None
    assert all(p.stat().st_size > 1000 for p in draw_episodes(tmp_path, stats, [[]], 4))


def test_every_task_row_carries_its_id(tmp_path, monkeypatch):
    # 90 tasks, more than the 40 that were labelled before: every row still names its task
    rows = [(10 * i, "task_start", "X-1", f"T-{i:02d}") for i in range(90)]
    rows += [(10 * i + 5, "task_finish", "X-1", f"T-{i:02d}") for i in range(90)]
    figures = []
    monkeypatch.setattr(gantt, "save_png", lambda fig, path: figures.append(fig) or path)
    gantt.gantt_tasks(make_events(sorted(rows)), tmp_path / "g.png")
    labels = [t.get_text() for t in figures[0].axes[0].get_yticklabels()]
    assert labels == [f"T-{i:02d}" for i in range(90)]  # by start time, the first on top


def test_a_comparisons_histograms_and_s_curves(tmp_path, monkeypatch):
    """One histogram panel per strategy with its own P50/P80/P90 from the summary, one
    S-curve colour per strategy; an episode from before ``task_end_times_s`` is left out of
    the S-curve, a strategy with no finished episode still gets its panel."""
    import media.episodes as episodes
    from training.runs.paired import summarize

    def row(strategy, seed, makespan, ends):
        r = {"strategy": strategy, "navigator": "scripted", "seed": seed, "stalled": False,
             "finished": makespan is not None, "timed_out": makespan is None,
             "makespan_s": makespan}
        return r if ends is None else {**r, "task_end_times_s": ends}

    rows = [row("priority", s, f[-1], f) for s, f in enumerate(FINISHES[:2])]
    rows += [row("priority", 2, 700.0, None),  # an old row: no end times
             row("nearest", 0, None, FINISHES[2])]
    summary = summarize(rows, 100.0, None)
    figures = []
    monkeypatch.setattr(episodes, "save_png", lambda fig, path: figures.append(fig) or path)
    episodes.draw_strategy_episodes(tmp_path, rows, summary, 4, 100.0)
    hist, curve = figures
    assert [ax.get_title(loc="left") for ax in hist.axes] == [
        "priority: 3 of 3 episodes finished", "nearest: 0 of 1 episodes finished"]
    # priority's 500, 610, 700: P50 610; P80 rank 1.6 -> 610 + 0.6 * 90 = 664
    labels = hist.axes[0].get_legend_handles_labels()[1]
    assert labels[:2] == ["P50 0.17 h (610 s)", "P80 0.18 h (664 s)"]  # on an axis of hours
    lines = curve.axes[0].get_legend_handles_labels()[1]
    assert lines == ["priority: median of 2 seeds, P80 0.18 h (664 s)",
                     "nearest: median of 1 seed"]


def test_with_a_calendar_the_episode_charts_are_dated(tmp_path, monkeypatch):
    """Second 0 Fri 2026-01-09 15:55, 08:00-16:00 Mon-Fri, Mon 12th a holiday: P50 of
    makespans 500, 610, 700 s is 610 s = Tue 13 Jan 08:05 (300 s on Friday, 310 on Tuesday);
    both charts get a date axis on top and hours of working time below."""
    import media.episodes as episodes
    from cmdp_pymunk.cases.model import Calendar

    calendar = Calendar(start="2026-01-09T15:55", holidays=["2026-01-12"])
    stats = {"makespans_s": [500.0, 610.0, 700.0], "p50_s": 610.0, "p80_s": None,
             "p90_s": None}
    figures = []
    monkeypatch.setattr(episodes, "save_png", lambda fig, path: figures.append(fig) or path)
    episodes.draw_episodes(tmp_path, stats, [[100.0, 500.0], [200.0, 610.0], [300.0, 700.0]],
                           2, calendar)
    for fig in figures:
        ax = fig.axes[0]
        assert "P50 0.17 h (610 s), Tue 13 Jan 08:05" in ax.get_legend_handles_labels()[1]
        assert ax.child_axes and "date (second 0: Fri 2026-01-09 15:55" in \
            ax.child_axes[0].get_xlabel()
    assert [f.axes[0].get_xlabel() for f in figures] == [
        "makespan (h of simulated working time)", "simulated working time (h)"]
