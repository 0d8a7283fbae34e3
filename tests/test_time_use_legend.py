"""time_use.png's legend speaks a planner's words (cmdp_pymunk.timeuse.CATEGORY_WORDS), not the
code's category names."""

from __future__ import annotations

from conftest import make_log

import media.comparison as comparison
from cmdp_pymunk.timeuse import CATEGORIES, CATEGORY_WORDS, time_use
from training.runs.paired import time_use_summary, time_use_table

CREWS = {"X-1": "XC", "K-1": "KC", "M-1": "MC", "M-2": "MC"}


def test_every_category_has_words_without_code_names():
    assert set(CATEGORY_WORDS) == set(CATEGORIES)
    assert not [w for w in CATEGORY_WORDS.values() if "_" in w]


def test_the_legend_shows_the_words(tmp_path, monkeypatch):
    entries = time_use_summary([{"strategy": "priority", "navigator": "scripted",
                                 "time_use_s": time_use(make_log().events, CREWS, 4, 500.0)}])
    figures = []
    monkeypatch.setattr(comparison, "_save", lambda fig, path: figures.append(fig) or path)
    comparison.draw_time_use(entries, tmp_path / "time_use.png")
    labels = figures[0].axes[0].get_legend_handles_labels()[1]
    assert labels == [CATEGORY_WORDS[c] for c in CATEGORIES]
    assert "idle: waiting for a predecessor" in labels and "idle_predecessor" not in labels


def test_the_table_heads_its_columns_with_the_words():
    # the what-if's and summaries' "Where the time goes" table, read by planners as well
    entries = time_use_summary([{"strategy": "priority", "navigator": "scripted",
                                 "time_use_s": time_use(make_log().events, CREWS, 4, 500.0)}])
    header = next(line for line in time_use_table(entries).splitlines()
                  if line.startswith("| strategy"))
    assert "idle: waiting for a predecessor" in header and "idle_predecessor" not in header
    assert header.count("|") == 3 + len(CATEGORIES) + 1
