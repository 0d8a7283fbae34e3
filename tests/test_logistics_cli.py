"""``--logistics SPEC`` of ``cmdp-simulate`` and ``cmdp-evaluate`` (issue 42 item 6, the user's
side): the one parser of the specs (``cmdp_pymunk.logistics.from_spec``), bad specs refused
before anything runs, the role played on the tiny case and recorded in every run's records,
and a resumed run refused with another role."""

from __future__ import annotations

import json
import pickle

import pytest

import cmdp_pymunk
from cmdp_pymunk.logistics import CraneIdle, Learned, Never, ReorderPoint, from_spec
from training.commands import evaluate_strategies as compare
from training.commands import simulate

TINY = str(cmdp_pymunk.TINY_CASE)
QUIET = ["--no-progress", "--no-charts"]
SHIPPED = "models/logistics_learned.json"


def read(path) -> dict:
    return json.loads(path.read_text())


# -- the parser ---------------------------------------------------------------------------------

def test_each_spec_names_its_role():
    assert from_spec("case") is None  # the engine's default: the case's reorder point
    assert isinstance(from_spec("never"), Never)
    reorder = from_spec("reorder:0.5")
    assert isinstance(reorder, ReorderPoint) and reorder.lifts == 0.5 and reorder.at is None
    assert from_spec("reorder:0").lifts == 0.0  # 0: never early, as Material.reorder_at
    assert isinstance(from_spec("crane-idle"), CraneIdle)
    learned = from_spec(f"learned:{SHIPPED}")
    shipped = read(cmdp_pymunk.TINY_CASE.parents[2] / SHIPPED)
    assert isinstance(learned, Learned) and list(learned.weights) == shipped["weights"]


@pytest.mark.parametrize("spec, words", [
    ("", ["one of", "case", "reorder:LIFTS"]),
    ("nevr", ["did you mean 'never'"]),
    ("crane_idle", ["did you mean 'crane-idle'"]),
    ("reorder", ["needs its LIFTS", "reorder:0.5"]),
    ("reorder:x", ["LIFTS 'x'", "reorder:0.5"]),
    ("reorder:-1", ["LIFTS '-1'", "0 or more"]),
    ("reorder:nan", ["LIFTS 'nan'"]),
    ("learned", ["needs its PATH", f"learned:{SHIPPED}"]),
    ("learned:", ["no model file", f"learned:{SHIPPED}"]),
    ("learned:no/such.json", ["no/such.json", "no such logistics model file"]),
])
def test_a_bad_spec_is_refused_with_the_fix(spec, words):
    with pytest.raises(ValueError) as err:
        from_spec(spec)
    text = str(err.value)
    assert text.startswith(f"--logistics {spec!r}") and "fix" in text, text
    assert all(w in text for w in words), text


def test_a_bad_model_file_names_its_entry(tmp_path):
    path = tmp_path / "m.json"
    path.write_text(json.dumps({"kind": "cmdp-logistics-linear", "features": ["stock_lifts"],
                                "weights": [1.0, 2.0], "bias": 0.0, "shares": [0.5]}))
    with pytest.raises(ValueError, match=r"--logistics 'learned:.*m\.json'.*'weights' has 2"):
        from_spec(f"learned:{path}")


def test_a_case_checks_that_the_role_fits_it():
    tiny = cmdp_pymunk.load_case(TINY)
    # half a lift of rebars (0.5 m3 a lift): a reorder point at 0.25 m3
    assert from_spec("reorder:0.5", case=tiny).levels("rebars") == (0.25,)
    with pytest.raises(ValueError) as err:  # fitted on the built-in floor's materials
        from_spec(f"learned:{SHIPPED}", case=tiny)
    text = str(err.value)
    assert text.startswith(f"--logistics 'learned:{SHIPPED}'") and "'tiny'" in text
    assert "fix: fit the rule on this case (materials rebars)" in text


# -- cmdp-simulate ------------------------------------------------------------------------------

def simulate_run(tmp_path, name: str, *options: str, case: str = TINY):
    out = tmp_path / name
    assert simulate.main(["--case", case, "--out", str(out), "--seed", "1", *QUIET,
                          *options]) == 0
    return out


def test_never_on_the_tiny_case_is_its_own_schedule(tmp_path, capsys):
    """The tiny case sets no reorder point: its own logistics is the paper's c7 (never)."""
    assert cmdp_pymunk.load_case(TINY).materials["rebars"].reorder_at == 0.0
    default = simulate_run(tmp_path, "default")
    assert "logistics case" in capsys.readouterr().out.splitlines()[0]
    never = simulate_run(tmp_path, "never", "--logistics", "never")
    assert "logistics never" in capsys.readouterr().out.splitlines()[0]
    for name in ("events.csv", "schedule.csv", "schedule.xml"):
        assert (default / name).read_bytes() == (never / name).read_bytes(), name
    assert read(default / "summary.json")["logistics"] == "case"
    assert read(never / "summary.json")["logistics"] == "never"


def test_a_reorder_spec_plays_the_case_with_that_reorder_point(tmp_path):
    """reorder:0.5 (half a lift, 0.25 m3 of rebars) changes only what the case's own
    reorder_at = 0.25 changes: both floors write the same bytes."""
    text = cmdp_pymunk.TINY_CASE.read_text()
    anchor = "crane_lift_quantity = 0.5"
    assert text.count(anchor) == 1
    case_file = tmp_path / "tiny_floor.toml"
    case_file.write_text(text.replace(anchor, anchor + "\nreorder_at = 0.25"))
    by_case = simulate_run(tmp_path, "by_case", case=str(case_file))
    by_role = simulate_run(tmp_path, "by_role", "--logistics", "reorder:0.5")
    plain = simulate_run(tmp_path, "plain")
    for name in ("events.csv", "schedule.csv"):
        assert (by_case / name).read_bytes() == (by_role / name).read_bytes(), name
    # and the reorder point acts on this seed: the role is not a no-op
    assert (plain / "events.csv").read_bytes() != (by_role / "events.csv").read_bytes()


def test_crane_idle_is_recorded_and_changes_only_the_lifts(tmp_path, capsys):
    plain = simulate_run(tmp_path, "plain")
    role = simulate_run(tmp_path, "role", "--logistics", "crane-idle")
    assert "logistics crane-idle" in capsys.readouterr().out
    before, after = read(plain / "summary.json"), read(role / "summary.json")
    assert after["logistics"] == "crane-idle" and before["logistics"] == "case"
    assert set(before) == set(after)
    assert {k for k in before if before[k] != after[k]} & {"case", "seed", "fidelity"} == set()
    # the two logs run alike until the role's first early lift
    a = (plain / "events.csv").read_text().splitlines()
    b = (role / "events.csv").read_text().splitlines()
    first = next(k for k, (x, y) in enumerate(zip(a, b, strict=False)) if x != y)
    assert first > 1 and "crane_request" in b[first], b[first]


@pytest.mark.parametrize("spec, words", [
    ("reorder:x", ["argument --logistics", "'reorder:x'", "fix"]),
    ("learned", ["argument --logistics", "needs its PATH", "fix"]),
    # a model fitted on another floor's materials does not fit the tiny case
    (f"learned:{SHIPPED}", ["--logistics", "'struts'", "fix: fit the rule on this case"]),
])
def test_simulate_refuses_a_bad_spec_before_anything_runs(tmp_path, capsys, spec, words):
    out = tmp_path / "o"
    assert status(simulate.main, ["--case", TINY, "--out", str(out), "--logistics", spec,
                                  *QUIET]) == 2
    err = capsys.readouterr().err
    assert all(w in err for w in words), err
    assert not out.exists()


def status(main, argv: list[str]) -> int:
    """A command's exit status, whether it returns it or exits at parse time (argparse)."""
    try:
        return main(argv)
    except SystemExit as err:
        return err.code


def test_the_workers_get_the_logistics():
    """The runner's arguments carry the spec to worker processes and Ray actors: they pickle,
    and each worker builds the role of its own."""
    from training.runs.base import make_runner

    case = cmdp_pymunk.load_case(TINY)
    runner = make_runner(pickle.loads(pickle.dumps((case, 3600.0, None, False, None, "pymunk",
                                                    None, "crane-idle"))))
    engine, _ = runner.play("priority", "scripted", 0)
    assert isinstance(engine.logistics, CraneIdle)
    assert runner._engine("priority", "scripted", undisrupted=True)[0].logistics is not None


# -- cmdp-evaluate ------------------------------------------------------------------------------

EVALUATE = ["--case", TINY, "--seeds", "0-1", "--strategies", "priority", "--workers", "1",
            "--no-progress", "--no-figures"]


def test_evaluate_plays_and_records_the_logistics(tmp_path, capsys):
    out = tmp_path / "e"
    assert compare.main([*EVALUATE, "--out", str(out), "--logistics", "reorder:0.5"]) == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert "logistics reorder:0.5" in header, header
    assert read(out / "settings.json")["logistics"] == "reorder:0.5"
    assert read(out / "resume.json")["logistics"] == "reorder:0.5"
    assert (out / "summary.md").read_text().startswith("Logistics reorder:0.5")
    # the episodes played the role: seed 1 as cmdp-simulate plays it
    rows = {r["seed"]: r for r in map(json.loads, (out / "episodes.jsonl").read_text()
                                      .splitlines())}
    simulated = read(simulate_run(tmp_path, "s", "--logistics", "reorder:0.5") / "summary.json")
    plain = read(simulate_run(tmp_path, "p") / "summary.json")
    assert rows[1]["makespan_s"] == simulated["makespan_s"] != plain["makespan_s"]


def test_evaluate_resumes_only_with_the_logistics_it_started_with(tmp_path, capsys):
    out = tmp_path / "e"
    argv = [*EVALUATE, "--seeds", "0", "--out", str(out)]
    assert compare.main([*argv, "--logistics", "never"]) == 0
    capsys.readouterr()
    assert compare.main([*argv, "--resume"]) == 2  # the case's own is another role
    assert "logistics" in capsys.readouterr().err
    assert compare.main([*argv, "--resume", "--logistics", "crane-idle"]) == 2
    assert compare.main([*argv, "--resume", "--logistics", "never"]) == 0


def test_a_run_from_before_the_option_resumes_with_the_cases_logistics(tmp_path, capsys):
    out = tmp_path / "e"
    argv = [*EVALUATE, "--seeds", "0", "--out", str(out)]
    assert compare.main(argv) == 0
    saved = read(out / "resume.json")
    assert saved.pop("logistics") == "case"  # as written before --logistics
    (out / "resume.json").write_text(json.dumps(saved))
    assert compare.main([*argv, "--resume", "--logistics", "never"]) == 2
    assert compare.main([*argv, "--resume"]) == 0


def test_evaluate_refuses_a_bad_spec_before_anything_runs(tmp_path, capsys):
    out = tmp_path / "e"
    assert status(compare.main, [*EVALUATE, "--out", str(out), "--logistics", "reorder"]) == 2
    assert "--logistics" in capsys.readouterr().err and not out.exists()
    assert compare.main([*EVALUATE, "--out", str(out), "--logistics", f"learned:{SHIPPED}"]) == 2
    assert "fix: fit the rule on this case" in capsys.readouterr().err and not out.exists()
