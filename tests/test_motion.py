"""One loop, many motions (issue 43): a third motion, docs/architecture.md's recipe as written,
runs the tiny case through the commands and a lookahead branch without touching the engine;
a clone put on a motion continues to the same schedule."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

import cmdp_pymunk
from agents.lookahead import LookaheadEvaluator, LookaheadSettings
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.eventfloor import EventFloor, WalkMotion, calibration_for, make_floor
from cmdp_pymunk.motion import Motion, PhysicsMotion, register_motion, registered_motions

TINY = str(cmdp_pymunk.TINY_CASE)


def _recipe() -> dict:
    """docs/architecture.md's motion recipe, run as written (so the page stays true)."""
    page = (Path(__file__).resolve().parents[1] / "docs" / "architecture.md").read_text()
    section = page[page.index("**A motion**"):]
    code = section[section.index("```python") + len("```python"):]
    code = code[:code.index("```")]
    namespace: dict = {}
    exec(compile(code, "docs/architecture.md", "exec"), namespace)
    return namespace


TeleportMotion = _recipe()["TeleportMotion"]


@pytest.fixture
def teleport():
    register_motion("teleport", lambda calibration: TeleportMotion())
    yield
    from cmdp_pymunk import motion
    motion._REGISTERED.pop("teleport", None)


def test_the_shipped_motions_and_a_third_one_are_motions():
    assert isinstance(PhysicsMotion(), Motion) and isinstance(WalkMotion(), Motion)
    assert isinstance(TeleportMotion(), Motion)


def test_a_third_motion_finishes_the_tiny_case_without_touching_the_engine(teleport):
    case = cmdp_pymunk.load_case(TINY)
    engine = make_floor(case, "teleport", evaluator="priority", stall_s=3600.0)
    assert type(engine) is Engine and engine.motion.name == "teleport"
    engine.reset(0)
    engine.run()
    assert engine.makespan_s is not None
    assert all(t.ended_s >= 0 for t in engine.site.tasks)
    # crews did travel, counted by the engine's one counter (metrics.Counters)
    assert sum(c.stats.distance_m for c in engine.site.crews) > 0
    assert sum(c.stats.reaching_steps for c in engine.site.crews) > 0
    again = make_floor(case, "teleport", evaluator="priority", stall_s=3600.0)
    again.reset(0)
    again.run()
    assert again.log.events == engine.log.events  # deterministic


def test_a_third_motion_runs_through_cmdp_simulate_and_cmdp_evaluate(teleport, tmp_path):
    from training.commands import evaluate_strategies as compare
    from training.commands import simulate

    out = tmp_path / "sim"
    assert simulate.main(["--case", TINY, "--out", str(out), "--seed", "1", "--no-progress",
                          "--no-charts", "--fidelity", "teleport"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["fidelity"] == "teleport"
    assert summary["makespan_s"] is not None
    ev = tmp_path / "eval"
    assert compare.main(["--case", TINY, "--seeds", "0-1", "--strategies", "priority",
                         "--workers", "1", "--out", str(ev), "--fidelity", "teleport",
                         "--no-progress"]) == 0
    assert (ev / "summary.json").exists()


def test_a_lookahead_branches_a_floor_on_a_third_motion(teleport):
    case = cmdp_pymunk.load_case(TINY)
    look = LookaheadEvaluator(settings=LookaheadSettings(candidates=2, futures=1))
    engine = make_floor(case, "teleport", evaluator=look, stall_s=3600.0)
    engine.reset(2)
    engine.run()
    assert engine.makespan_s is not None
    assert look.decisions, "the lookahead branched at least one decision"
    assert all(len(d.makespans_s) == len(d.candidates) >= 2 for d in look.decisions)
    assert all(math.isfinite(m) for d in look.decisions for m in d.makespans_s)


def test_registering_refuses_a_shipped_name_and_bad_names():
    with pytest.raises(ValueError, match="taken"):
        register_motion("event", lambda c: WalkMotion(c))
    with pytest.raises(ValueError, match="identifier"):
        register_motion("tele port", lambda c: TeleportMotion())
    assert "tele port" not in registered_motions()


def test_a_clone_put_on_the_walk_motion_continues_as_the_floor_itself():
    """An event floor cloned onto a fresh walk motion (the old ``from_engine``) plays the same
    schedule to the end as the floor it came from."""
    case = cmdp_pymunk.load_case(cmdp_pymunk.BUILTIN_CASE)
    calibration = calibration_for(case)
    floor = EventFloor(case, evaluator="priority", stall_s=3600.0, calibration=calibration)
    floor.reset(4)
    while floor.site.tasks_ended < 10:
        floor.advance(None)
    moved = floor.clone(motion=WalkMotion(calibration))
    assert moved.motion is not floor.motion and moved.spans_run == 0
    floor.run()
    moved.run()
    assert moved.makespan_s == floor.makespan_s
    assert moved.log.events == floor.log.events


def test_a_pymunk_floor_put_on_the_walk_motion_leaves_the_original_as_it_was():
    case = cmdp_pymunk.load_case(TINY)
    engine = Engine(case, evaluator="priority", park_idle=True)
    engine.reset(0)
    from agents.navigator import Navigator
    navigator = Navigator()
    navigator.reset(0)
    while engine.site.tasks_ended == 0:
        engine.advance(navigator.actions(engine, None), until=engine.decision_due)
    before = list(engine.log.events)
    walk = engine.clone(keep_log=False, motion=WalkMotion(calibration_for(case)))
    assert isinstance(engine.motion, PhysicsMotion) and walk.motion.name == "event"
    assert walk.log.events == [] and walk.position_log_every_s is None
    walk.run()
    assert walk.makespan_s is not None and engine.log.events == before
    with pytest.raises(ValueError, match="reaching actions"):
        engine.run()  # the physics motion needs its low level
