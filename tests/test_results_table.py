"""benchmarks/results_table.py: its statistics by hand, and a tiny table end to end."""

import importlib.util
import json
from pathlib import Path

import pytest

PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "results_table.py"
spec = importlib.util.spec_from_file_location("results_table", PATH)
table = importlib.util.module_from_spec(spec)
spec.loader.exec_module(table)


def test_interquartile_mean_and_bootstrap_by_hand():
    # 8 values: a quarter (2) cut from each end -> mean of 3, 4, 5, 6 = 4.5 (100 is cut)
    assert table.iqm([1, 2, 3, 4, 5, 6, 7, 100]) == 4.5
    assert table.bootstrap_ci([7.0, 7.0, 7.0]) == (7.0, 7.0)
    assert table.bootstrap_ci([1.0]) is None
    lo, hi = table.bootstrap_ci([1.0, 2, 3, 4, 5, 6, 7, 8, 9, 10])
    assert 1.0 <= lo < 5.5 < hi <= 10.0
    assert table.bootstrap_ci([1.0, 2, 3, 4]) == table.bootstrap_ci([1.0, 2, 3, 4])  # seeded


def test_random_values_are_seeded_and_in_range():
    class Crew:
        scope = (3, 5, 8)

    a, b = table.RandomEvaluator(4), table.RandomEvaluator(4)
    va = a.target_values(Crew, None, (0, 0))
    assert va == b.target_values(Crew, None, (0, 0)) and set(va) == {3, 5, 8}
    assert all(0.5 <= v <= 1.0 for v in va.values())


def test_a_tiny_table_end_to_end(tmp_path, capsys):
    out = tmp_path / "t"
    assert table.main(["--ids", "cmdp/TinyFloor-v1", "--seeds", "0-1", "--strategies",
                       "priority,ga:models/ga_priorities.json", "--workers", "1",
                       "--out", str(out)]) == 0
    text = (out / "table.md").read_text()
    assert "### `cmdp/TinyFloor-v1`" in text and "| priority | 2/2 |" in text
    assert "`ga:models/ga_priorities.json` left out" in text  # made for the built-in case
    data = json.loads((out / "table.json").read_text())["summary"]["cmdp/TinyFloor-v1"]
    assert data["priority"]["makespan_s"]["n"] == 2
    assert table.main(["--ids", "cmdp/Nope-v1", "--out", str(out)]) == 2
    assert "unknown id" in capsys.readouterr().err


if __name__ == "__main__":
    pytest.main([__file__])
