"""One loop, many motions (issue 43): a third motion written from docs/architecture.md's recipe
runs the tiny case through the commands and a lookahead branch without touching the engine;
a clone put on a motion continues to the same schedule."""

from __future__ import annotations

import json
import math

import pytest

import cmdp_pymunk
from agents.lookahead import LookaheadEvaluator, LookaheadSettings
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.eventfloor import EventFloor, WalkMotion, calibration_for, make_floor
from cmdp_pymunk.eventfloor.floor import EventPlane
from cmdp_pymunk.motion import (
    Motion,
    PhysicsMotion,
    Span,
    register_motion,
    registered_motions,
    tick_reach_clock,
)
from cmdp_pymunk.move import congested_velocity
from cmdp_pymunk.policy import best_target
from cmdp_pymunk.state import Site

TINY = str(cmdp_pymunk.TINY_CASE)


class TeleportMotion:
    """The recipe's example: a crew that holds target values stands still for the time Eq. 1
    gives over the straight line to its best target (its nominal forward velocity, no
    congestion) and is then at the target's centre. Spans of one second."""

    name = "teleport"
    takes_actions = False  # no low level: crews are placed
    invasion_of = None  # Eq. 2 with the crews standing in the area

    def plane(self, case, site: Site):
        return EventPlane(case, site)  # points on a plane: pose, place, nothing collides

    def check(self, engine) -> None:
        if engine.stage != 2:
            raise ValueError("teleport: stage 2 only")

    def begin(self, engine) -> None:
        self.trips = [None] * len(engine.case.crews)  # (target, arrival second, x, y)

    def span_s(self, engine) -> int:
        return 1

    def quiet(self, engine) -> bool:
        return False

    def needs_action(self, engine, crew) -> bool:
        return False

    def position_due(self, engine, crew) -> bool:
        return self.trips[crew.index] is not None

    def move(self, engine, actions, span: Span) -> None:
        site, then = engine.site, engine.site.time_s + span.seconds
        cap = site.case.simulation.reevaluate_after_steps
        for crew in site.crews:
            trip = self.trips[crew.index]
            if not crew.moving or trip is None:
                span.had_target[crew.index] = False
                continue
            if crew.scope:
                span.timeouts[crew.index] = tick_reach_clock(crew, span.seconds, cap)
            if then >= trip[1]:
                px, py = engine.positions[crew.index]
                span.distance_m[crew.index] = math.hypot(trip[2] - px, trip[3] - py)
                engine.positions[crew.index] = (trip[2], trip[3])
                engine.world.place(crew.index, (trip[2], trip[3]))

    def end_span(self, engine, span: Span, ctx) -> None:
        self.replan(engine)

    def replan(self, engine) -> None:
        site = engine.site
        for crew in site.crews:
            target = best_target(crew) if crew.moving else -1
            trip = self.trips[crew.index]
            if target < 0:
                self.trips[crew.index] = None
            elif trip is None or trip[0] != target:
                x, y = _centre(site, crew, target)
                px, py = engine.positions[crew.index]
                v = congested_velocity(crew.spec.velocity_m_s, 1.0, 1.0, 0.0)  # Eq. 1, open
                self.trips[crew.index] = (target, site.time_s + math.ceil(
                    math.hypot(x - px, y - py) / v), x, y)


def _centre(site: Site, crew, target: int) -> tuple[float, float]:
    """The middle of the region that counts a target reached (``decide.reached_target``)."""
    if target == site.outlet_target:
        plane = site.case.plane
        return plane.outlet_x_m, plane.outlet_y_m
    if target >= len(site.components):
        x0, y0, x1, y1 = site.storages[target - len(site.components)].rect
    else:
        x0, y0, x1, y1 = site.tasks[crew.scope[target]].area
    return (x0 + x1) / 2, (y0 + y1) / 2


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
    from training import compare, simulate

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
