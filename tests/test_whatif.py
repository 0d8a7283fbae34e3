"""cmdp-evaluate's paired what-if (training/whatif.py): its differences are two runs
subtracted, and the ordinary summary reports cost beside the makespan. On the event floor of
the tiny case (a second or two)."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from cmdp_pymunk.cases.levers import make_variant, variant_toml
from cmdp_pymunk.cases.load import TINY_CASE, load_case
from cmdp_pymunk.cost import case_cost
from training.commands import evaluate_strategies as compare

COMMON = ["--seeds", "0-2", "--strategies", "priority", "--workers", "1", "--fidelity",
          "event", "--no-progress", "--no-figures"]


def episodes(path) -> dict:
    with open(path / "episodes.csv", newline="") as f:
        return {(r.get("variant", ""), int(r["seed"])): r for r in csv.DictReader(f)}


def test_a_paired_what_if_equals_two_runs_subtracted(tmp_path):
    tiny = load_case(TINY_CASE)
    variant = make_variant(tiny, "crews.RC+1")
    variant_file = tmp_path / "more_rc.toml"
    variant_file.write_text(variant_toml(variant))
    assert compare.main(["--case", str(TINY_CASE), "--variant", "more_rc=crews.RC+1",
                         *COMMON, "--out", str(tmp_path / "whatif")]) == 0
    assert compare.main(["--case", str(TINY_CASE), *COMMON, "--out", str(tmp_path / "a")]) == 0
    assert compare.main(["--case", str(variant_file), *COMMON, "--out", str(tmp_path / "b")]) == 0
    whatif, a, b = (episodes(tmp_path / d) for d in ("whatif", "a", "b"))
    diffs, cost_diffs = [], []
    for seed in range(3):
        base, more = whatif[("tiny", seed)], whatif[("more_rc", seed)]
        # each case or variant plays as it would alone
        assert float(base["makespan_s"]) == float(a[("", seed)]["makespan_s"])
        assert float(more["makespan_s"]) == float(b[("", seed)]["makespan_s"])
        assert float(more["cost"]) == pytest.approx(float(b[("", seed)]["cost"]))
        diffs.append(float(b[("", seed)]["makespan_s"]) - float(a[("", seed)]["makespan_s"]))
        cost_diffs.append(float(b[("", seed)]["cost"]) - float(a[("", seed)]["cost"]))
        # the cost is the named function of the row's makespan, crews and lifts
        assert float(more["cost"]) == pytest.approx(case_cost(
            variant.case, float(more["makespan_s"]), int(more["crane_lifts"])))
    summary = {e["variant"]: e for e in json.loads((tmp_path / "whatif" / "whatif.json")
                                                   .read_text())}
    assert summary["more_rc"]["vs_base_paired_seeds"] == 3
    assert summary["more_rc"]["vs_base_makespan_diff_mean_s"] == pytest.approx(np.mean(diffs))
    assert summary["more_rc"]["vs_base_cost_diff_mean"] == pytest.approx(np.mean(cost_diffs))
    assert summary["more_rc"]["crews"] == "HIC 1, RC 2"
    table = (tmp_path / "whatif" / "whatif.md").read_text()
    assert "| more_rc | RC+1 | HIC 1, RC 2 |" in table and "Not paired: a changed crew" in table
    assert load_case(tmp_path / "whatif" / "variants" / "more_rc.toml") == variant.case
    # the ordinary summary: cost P50/P80 beside the makespan's
    plain = json.loads((tmp_path / "a" / "summary.json").read_text())[0]
    costs = [float(a[("", s)]["cost"]) for s in range(3)]
    assert plain["cost_p80"] == pytest.approx(np.percentile(costs, 80))
    assert "## Cost (EUR)" in (tmp_path / "a" / "summary.md").read_text()


@pytest.mark.parametrize("extra, words", [
    (["--variant", "more=crews.RX+1"], ['--variant more: 1 problem(s)', 'no crew type "RX"']),
    (["--variant", "crews.RC+1"], ["is not NAME=CHANGES; fix"]),
    (["--variant", "v=RC+1", "--resume"], ["--resume does not go with a what-if"]),
])
def test_a_bad_what_if_is_refused_before_anything_runs(tmp_path, capsys, extra, words):
    out = tmp_path / "out"
    try:
        code = compare.main(["--case", str(TINY_CASE), *COMMON, "--out", str(out), *extra])
    except SystemExit as exit_:  # argparse's own errors
        code = exit_.code
    assert code == 2
    err = capsys.readouterr().err
    assert all(w in err for w in words), err
    assert not (out / "episodes.jsonl").exists()
