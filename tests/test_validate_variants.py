"""benchmarks/validate_variants.py (issue 42 item 4): a variant on its base's calibration, the
event floor against the pymunk floor. The full run is a benchmark (docs/event-floor.md); here
one variant of the tiny case on 2 seeds, its numbers recomputed from the per-seed makespans."""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from cmdp_pymunk import TINY_CASE, load_case

PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "validate_variants.py"
spec = importlib.util.spec_from_file_location("validate_variants", PATH)
vv = importlib.util.module_from_spec(spec)
spec.loader.exec_module(vv)


def test_relative_error_by_hand():
    assert vv.relative_error(103.0, 100.0) == pytest.approx(0.03)
    assert vv.relative_error(None, 100.0) is None


def test_one_variant_on_two_seeds_both_floors(tmp_path, capsys):
    assert vv.main(["--case", str(TINY_CASE), "--seeds", "0-1", "--variant", "crews.RC+1",
                    "--workers", "1", "--out", str(tmp_path)]) == 0
    result = json.loads((tmp_path / "validate_variants.json").read_text())
    base, more = result["entries"]
    assert (base["entry"], more["entry"]) == ("base", "crews.RC+1")
    for e in (base, more):
        for floor in ("pymunk", "event"):
            ms = e[floor]["makespans_s"]
            assert len(ms) == 2 and e[floor]["mean_s"] == pytest.approx(np.mean(ms))
        # the tiny floor's two floors stay close (measured about 1 %; loosely here)
        assert abs(e["mean_error"]) < 0.10
        assert e["mean_error"] == pytest.approx(e["event"]["mean_s"] / e["pymunk"]["mean_s"] - 1)
    # one more RC crew shortens the tiny floor on both floors (measured about -790 s)
    for floor in ("pymunk", "event"):
        diffs = np.subtract(more[floor]["makespans_s"], base[floor]["makespans_s"])
        assert more[floor]["vs_base_diff_mean_s"] == pytest.approx(diffs.mean())
        assert diffs.mean() < 0
    assert isinstance(more["diff_inside_pymunk_interval"], bool)
    assert "| crews.RC+1 |" in capsys.readouterr().out
    assert load_case(TINY_CASE).case.name in result["case"]


def test_checkpoint_resumes_without_running_again(tmp_path, monkeypatch):
    """Each floor is appended to the checkpoint as it ends; a second run on a prefix of the
    seeds reads them back and runs nothing (a cut last line is run again)."""
    case = load_case(TINY_CASE)
    ck = tmp_path / "floors.jsonl"
    first = vv.validate_variants(case, [], [0, 1], checkpoint=ck)
    lines = ck.read_text().splitlines()
    # seed by seed: the base on both floors for seed 0, then for seed 1
    assert [(json.loads(x)["floor"], json.loads(x)["seed"]) for x in lines] == \
        [("pymunk", 0), ("event", 0), ("pymunk", 1), ("event", 1)]
    ck.write_text("\n".join(lines) + '\n{"entry": "base", "floor"')  # a killed run's last line

    def no_floor(*args, **kwargs):
        raise AssertionError("a floor held by the checkpoint ran again")

    monkeypatch.setattr(vv, "whatif_job", no_floor)
    again = vv.validate_variants(case, [], [0], checkpoint=ck)
    for floor in ("pymunk", "event"):
        assert again["entries"][0][floor]["makespans_s"] == \
            first["entries"][0][floor]["makespans_s"][:1]


def test_lever_gap_by_hand():
    """The two floors' effects against each other, per seed: (event var - event base) -
    (pymunk var - pymunk base); a seed some floor did not finish is left out."""
    def rows(*makespans):
        return [{"seed": s, "makespan_s": m, "finished": m is not None}
                for s, m in enumerate(makespans)]

    table = {("base", "pymunk"): rows(100.0, 200.0, 300.0, 400.0),
             ("v", "pymunk"): rows(90.0, 180.0, 290.0, 350.0),     # effects -10 -20 -10 -50
             ("base", "event"): rows(110.0, 190.0, 310.0, None),
             ("v", "event"): rows(100.0, 150.0, 330.0, 400.0)}    # effects -10 -40 +20 (-)
    gap = vv._lever_gap(table, "v")
    gaps = [0.0, -20.0, 30.0]  # seeds 0-2: event effect less pymunk effect
    half = 4.302653 * np.std(gaps, ddof=1) / np.sqrt(3)  # Student's t, 2 degrees of freedom
    assert gap["lever_gap_mean_s"] == pytest.approx(np.mean(gaps))
    assert gap["lever_gap_ci95_s"] == pytest.approx(half, rel=1e-4)
    assert gap["lever_gap_holds_0"] is True
    assert vv._lever_gap({k: v[:1] for k, v in table.items()}, "v")["lever_gap_mean_s"] is None
