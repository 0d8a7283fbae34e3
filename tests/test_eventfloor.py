"""The event floor (issue 30): a hand-worked timeline, the pymunk floor's paces and
disruptions, branching both ways, determinism, and the checks on its inputs."""

import math

import numpy as np
import pytest

import cmdp_pymunk
from agents.navigator import Navigator
from cmdp_pymunk import move
from cmdp_pymunk.cases.load import CaseError, case_from_dict
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.eventfloor import EventFloor, WalkMotion, make_floor
from cmdp_pymunk.eventfloor.calibration import (
    Calibration,
    CrewTypeCalibration,
    calibration_for,
    fingerprint,
    load_calibration,
    uncalibrated,
    write_calibration,
)
from cmdp_pymunk.eventfloor.walks import (
    WalkPlanner,
    _interp,
    congestion_along,
    congestion_areas,
)
from cmdp_pymunk.rollout import play, run_episode
from cmdp_pymunk.state import Site


def line_case(**changes) -> dict:
    """Two crews, three tasks, paths along grid rows and columns (worked out below)."""
    data = {
        "case": {"name": "line"},
        "plane": {"width_m": 20.0, "height_m": 12.0, "outlet_x_m": -9.0, "outlet_y_m": 0.0},
        "crane": {"x_m": 0.0, "y_m": 5.0, "lift_time_s": 120.0, "assist_time_s": 90.0},
        "task_types": {
            "HI": {"name": "hoisting", "crew_type": "HIC", "area_distance_m": 1.0,
                   "congestion_index": 0.5, "needs_crane": True},
            "J": {"name": "joint", "crew_type": "JC", "area_distance_m": 1.0,
                  "congestion_index": 0.5}},
        "crew_types": {
            "HIC": {"name": "hoisting crew", "duration_mean_min": 10.0, "duration_sd_min": 0.0,
                    "occupation_area_m2": 1.0, "velocity_m_s": 0.5, "invasion_index": 0.5},
            "JC": {"name": "joint crew", "duration_mean_min": 5.0, "duration_sd_min": 0.0,
                   "occupation_area_m2": 1.0, "velocity_m_s": 0.5, "invasion_index": 0.5}},
        "crews": [{"id": "HIC-1", "type": "HIC", "start_x_m": -8.25, "start_y_m": 2.25},
                  {"id": "JC-1", "type": "JC", "start_x_m": -8.25, "start_y_m": -2.25}],
        "components": [
            {"id": "C1", "kind": "precast", "x_m": 0.25, "y_m": 2.25, "width_m": 1.0,
             "height_m": 1.0},
            {"id": "C2", "kind": "joint", "x_m": 0.25, "y_m": -2.25, "width_m": 1.0,
             "height_m": 1.0}],
        "tasks": [{"id": "T1", "type": "HI", "component": "C1"},
                  {"id": "T2", "type": "J", "component": "C2"},
                  {"id": "T3", "type": "J", "component": "C1", "predecessors": ["T1"]}],
    }
    data.update(changes)
    return data


def test_a_hand_worked_timeline():
    """Grid cells of 0.5 m, centres at -9.75, -9.25, ...; crews of 1 m2 (radius 0.564 m);
    nothing congested on their paths; walk factor 1.

    HIC-1 walks along the row y = 2.25 from x = -8.25 to the first cell of C1's task area's
    approach band (area x from -1.25, band 0.6 m: the cell at -1.75), 13 cells = 6.5 m, then
    into the area at x = -1.24, 0.51 m: 7.01 m at 0.5 m/s = 14.02 s, so it reaches at t = 15.
    T1 starts (c1) and asks for the crane (c8): 90 s of assistance, working from t = 105;
    600 s a unit (10 min, sd 0): T1 ends at 705. JC-1 walks the same way along y = -2.25 and
    reaches at 15 too, but HIC-1's start (first in crew order) changed the site, so its scope
    is stale: it re-acquires (c10) and starts T2 a second later, as the pymunk engine would:
    T2 from 16, 300 s, ends at 316; T3 waits for T1. At 705 JC-1 walks from (-1.24, -2.25):
    0.01 m to its cell's centre, up the column x = -1.25 to the band's first cell (y = 0.25),
    2.5 m, into T3's area at (-1.24, 0.76), 0.5101 m: 3.0201 m = 6.04 s, reach at 712;
    T3 takes 300 s: 1,012."""
    floor = EventFloor(case_from_dict(line_case()), evaluator="priority")
    floor.reset(0)
    floor.run()
    times = {(e.kind, e.subject): e.time_s for e in floor.log.events
             if e.kind in ("task_start", "task_finish")}
    assert times == {("task_start", "T1"): 15.0, ("task_start", "T2"): 16.0,
                     ("task_finish", "T2"): 316.0, ("task_finish", "T1"): 705.0,
                     ("task_start", "T3"): 712.0, ("task_finish", "T3"): 1012.0}
    crane = [(e.time_s, e.kind) for e in floor.log.events if e.kind.startswith("crane")]
    assert crane == [(15.0, "crane_request"), (105.0, "crane_done")]
    assert floor.makespan_s == 1012.0


def test_the_pymunk_floor_runs_the_line_case_close_to_the_hand_timeline():
    case = case_from_dict(line_case())
    engine = Engine(case, evaluator="priority", park_idle=True)
    episode = run_episode(engine, Navigator(), 0, 3600, progress=False)
    assert episode.makespan_s == pytest.approx(1012, abs=40)  # turning and docking, not more


def test_paces_equal_the_pymunk_floors_task_by_task():
    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    engine = Engine(case, evaluator="priority", park_idle=True)
    run_episode(engine, Navigator(), 5, 3600, progress=False)
    floor = EventFloor(case, evaluator="priority")
    floor.reset(5)
    floor.run()
    assert floor.makespan_s is not None
    assert [t.pace for t in floor.site.tasks] == [t.pace for t in engine.site.tasks]
    assert all(t.pace > 0 for t in floor.site.tasks)


def events_of(floor):
    return [(e.time_s, e.kind, e.crew, e.subject, e.detail) for e in floor.log.events]


def test_same_seed_twice_gives_the_same_event_log_and_seeds_differ():
    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    logs = []
    for seed in (3, 3, 4):
        floor = EventFloor(case, evaluator="priority")
        floor.reset(seed)
        floor.run()
        logs.append(events_of(floor))
    assert logs[0] == logs[1]
    assert logs[0] != logs[2]


def test_a_clone_continued_equals_the_original():
    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    floor = EventFloor(case, evaluator="priority")
    floor.reset(2)
    while floor.site.tasks_ended == 0:
        floor.advance(None)
    branch = floor.clone()
    floor.run()
    branch.run()
    assert events_of(branch) == events_of(floor)
    assert branch.makespan_s == floor.makespan_s


def test_a_floor_built_from_a_pymunk_floor_at_a_decision_continues_and_finishes():
    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    engine = Engine(case, evaluator="priority", park_idle=True)
    navigator = Navigator()
    engine.reset(1)
    navigator.reset(1)
    while engine.site.tasks_ended == 0:  # a task ends: a decision (the crews re-acquire)
        engine.advance(navigator.actions(engine, None), until=engine.decision_due)
    started = {t.id for t in engine.site.tasks if t.started_s >= 0 or t.ended_s >= 0}
    floor = engine.clone(keep_log=False, motion=WalkMotion())
    assert floor.site is not engine.site and floor.site.time_s == engine.site.time_s
    assert [floor.pose(i)[:2] for i in range(2)] == [engine.pose(i)[:2] for i in range(2)]
    floor.run()
    assert floor.makespan_s is not None and floor.makespan_s > engine.site.time_s
    # the pymunk floor is untouched and goes on by itself
    assert {t.id for t in engine.site.tasks if t.started_s >= 0 or t.ended_s >= 0} == started
    play(engine, navigator)
    assert engine.makespan_s is not None


@pytest.mark.parametrize("evaluator", ["priority", "nearest", "uniform"])
def test_the_evaluators_run_unchanged_on_both_floors(evaluator):
    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    for fidelity in ("pymunk", "event"):
        floor = make_floor(case, fidelity, evaluator=evaluator, park_idle=True)
        episode = run_episode(floor, Navigator(), 0, 3600, progress=False)
        assert episode.makespan_s is not None, fidelity


def test_values_from_outside_stop_the_event_floor_as_the_pymunk_one():
    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    floor = EventFloor(case, evaluator=None)
    floor.reset(0)
    asked = 0
    while not floor.site.done:
        while floor.pending:
            i = floor.pending[0]
            floor.set_target_values(i, {t: 1.0 for t in floor.site.crews[i].scope})
            asked += 1
        if floor.advance(None, until=lambda: False).truncated:
            break
    assert floor.site.done and asked >= 3


def disrupted_tiny() -> dict:
    import tomllib

    data = tomllib.loads(cmdp_pymunk.TINY_CASE.read_text())
    data["disruptions"] = {
        "crane_breakdowns": [{"at_s": 200.0, "duration_s": 300.0}],
        "weather_stops": [{"mean_interval_s": 900.0, "duration_s": 120.0}],
        "absences": [{"crew": "RC-1", "at_s": 1000.0, "duration_s": 400.0}]}
    return data


def test_disruptions_land_at_the_same_times_on_both_floors():
    case = case_from_dict(disrupted_tiny())
    starts = []
    for fidelity in ("pymunk", "event"):
        floor = make_floor(case, fidelity, evaluator="priority", park_idle=True,
                           max_time_s=2500.0)
        run_episode(floor, Navigator(), 7, None, progress=False)
        starts.append([(e.time_s, e.kind, e.detail) for e in floor.log.events
                       if e.kind.startswith("disruption") and e.time_s <= 2000])
    assert starts[0] == starts[1]
    assert {d for _, _, d in starts[0]} == {"crane_breakdown", "weather", "absence"}


def test_congestion_along_a_path_is_eq1s_index_point_by_point():
    case = cmdp_pymunk.load_case()
    site = Site(case, 2)
    for t in (0, 5, 9):
        site.active_areas.append(t)
    site.storages[0].stock = site.storages[0].capacity / 2
    rng = np.random.default_rng(0)
    hw, hh = case.plane.half_extents
    xs, ys = rng.uniform(-hw, hw, 400), rng.uniform(-hh, hh, 400)
    got = congestion_along(site, xs, ys)
    want = [move.congestion_index(site, x, y) for x, y in zip(xs, ys, strict=True)]
    assert got.tolist() == want
    assert min(want) < 1.0


def test_a_walks_congestion_from_its_kept_path_is_congestion_along_it():
    """What a walk reads of Eq. 1's I_area (the areas each kept path's points lie in, kept
    per path and area) is ``congestion_along`` its points, whatever the areas on the plane;
    its distances are its points' own."""
    case = cmdp_pymunk.load_case()
    site = Site(case, 2)
    planner = WalkPlanner(site)
    crew = site.crews[0]
    rng = np.random.default_rng(1)
    hw, hh = case.plane.half_extents
    for trial in range(40):
        site.active_areas[:] = rng.choice(len(site.tasks), 6, replace=False).tolist()
        for storage in site.storages:
            storage.stock = storage.capacity * rng.choice([0.0, 0.3, 1.0])
        task = site.tasks[site.active_areas[0]]
        crew.scope = {task.component: task.index}
        start = (float(rng.uniform(-hw, hw)), float(rng.uniform(-hh, hh)))
        walk = planner.walk(site, crew, start, task.component, 0.0, 1.0)
        path = planner.path(site, crew, start, task.component, task.index)
        got = planner._congestion(site, path, start)
        want = congestion_along(site, np.asarray(walk.xs[:-1]), np.asarray(walk.ys[:-1]))
        if got is None:  # every point outside every area
            assert (want == 1.0).all(), trial
        else:
            assert got == want.tolist(), trial
        # the areas given by the caller (one event's walks share them): the same
        assert planner._congestion(site, path, start, congestion_areas(site)) == got
        # and its metres at each point are its steps' (made from the kept path's steps)
        steps = np.hypot(np.diff(walk.xs), np.diff(walk.ys))
        assert walk.distances == np.concatenate(((0.0,), np.cumsum(steps))).tolist()


def test_the_walks_interpolation_is_numpys_to_the_last_bit():
    """A walk's distance at a time (``Walk.distance_at``) is numpy.interp done on lists: the
    same float at the ends, before the start, on a point, on repeated times (a step of zero
    length) and between points; random paths with random times too."""
    xp, fp = [0.0, 0.0, 1.5, 1.5, 4.0], [0.0, 0.0, 0.7, 0.9, 2.0]
    for x in (-1.0, 0.0, 0.3, 1.5, 2.0, 4.0, 9.0):
        assert _interp(x, xp, fp) == float(np.interp(x, xp, fp)), x
    rng = np.random.default_rng(0)
    for _ in range(200):
        times = np.concatenate(((0.0,), np.cumsum(rng.exponential(1.0, 30))))
        metres = np.concatenate(((0.0,), np.cumsum(rng.exponential(0.5, 30))))
        for x in rng.uniform(-1.0, times[-1] + 1.0, 20).tolist() + times.tolist():
            assert _interp(x, times.tolist(), metres.tolist()) == \
                float(np.interp(x, times, metres))


def test_bad_inputs_are_refused_with_the_fix(tmp_path):
    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    with pytest.raises(ValueError, match="stage 2 only"):
        EventFloor(case, stage=1)
    with pytest.raises(ValueError, match="'pymunk'.*'event'"):
        make_floor(case, "events")
    other = Calibration(case="other", fingerprint="0" * 16, fitted_on="x",
                        crew_types={"RC": CrewTypeCalibration(walk_factor=1.2)})
    path = write_calibration(other, tmp_path / "other.event.toml")
    with pytest.raises(CaseError, match="another floor"):
        load_calibration(path, case)
    (tmp_path / "bad.event.toml").write_text("[event_floor]\ncase = 'tiny'\n")
    with pytest.raises(CaseError, match="fingerprint"):
        load_calibration(tmp_path / "bad.event.toml", case)


def test_a_calibration_round_trips_and_is_found_beside_its_case(tmp_path):
    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    mine = Calibration(case="tiny", fingerprint=fingerprint(case), fitted_on="test",
                       crew_types={"RC": CrewTypeCalibration(walk_factor=1.25,
                                                             task_invasion=0.1)})
    case_path = tmp_path / "tiny.toml"
    case_path.write_text(cmdp_pymunk.TINY_CASE.read_text())
    write_calibration(mine, tmp_path / "tiny.event.toml")
    assert calibration_for(case, case_path) == mine
    assert calibration_for(case).calibrated is False  # none built in for the tiny floor
    assert calibration_for(cmdp_pymunk.load_case()).calibrated  # the built-in case's
    # a calibration slows the floor as its numbers say
    slow = EventFloor(case, evaluator="priority", calibration=mine)
    fast = EventFloor(case, evaluator="priority", calibration=uncalibrated(case))
    for floor in (slow, fast):
        floor.reset(0)
        floor.run()
    assert slow.makespan_s > fast.makespan_s


def test_the_disrupted_built_in_case_runs_on_the_built_in_calibration():
    plain, disrupted = cmdp_pymunk.load_case(), cmdp_pymunk.load_case(cmdp_pymunk.DISRUPTED_CASE)
    assert fingerprint(plain) == fingerprint(disrupted)
    assert calibration_for(disrupted) == calibration_for(plain)


def eq9_on_both_floors(case, seeds, calibration=None) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 9's makespans on the pymunk floor and on the event floor, seed by seed."""
    engine = Engine(case, evaluator="priority", park_idle=True)
    floor = EventFloor(case, evaluator="priority", calibration=calibration)
    pairs = []
    for seed in seeds:
        a = run_episode(engine, Navigator(), seed, 3600, progress=False).makespan_s
        floor.reset(seed)
        floor.run()
        pairs.append((a, floor.makespan_s))
    return np.array(pairs).T


def test_tiny_floors_correlate_with_the_pymunk_floors():
    """The validation's small version in the gate: 10 tiny floors on both."""
    a, b = eq9_on_both_floors(cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE), range(10))
    assert np.corrcoef(a, b)[0, 1] >= 0.8
    assert abs(b.mean() / a.mean() - 1) < 0.1
    assert not math.isnan(a.sum() + b.sum())


def test_a_disruption_longer_than_the_stall_guard_is_no_stall():
    """The guard counts no disrupted second (as on the pymunk floor, whose mark moves every
    one of them): a weather stop of 5,000 s under a guard of 3,600 s is waited out."""
    data = disrupted_tiny()
    data["disruptions"] = {"weather_stops": [{"at_s": 300.0, "duration_s": 5000.0}]}
    floor = EventFloor(case_from_dict(data), evaluator="priority", stall_s=3600.0)
    floor.reset(0)
    floor.run()
    assert floor.stalled is None and floor.makespan_s > 5300


def test_the_lookahead_thinks_on_the_event_floor_and_acts_on_the_pymunk_one():
    from agents.specs import evaluator_from_spec

    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    lookahead = evaluator_from_spec("lookahead:candidates=2+futures=2+floor=event")
    engine = Engine(case, evaluator=lookahead, park_idle=True)
    episode = run_episode(engine, Navigator(), 0, 3600, progress=False)
    assert episode.makespan_s is not None
    summary = lookahead.summary()
    assert summary["thinks_on"] == "event" and summary["decisions"] >= 1
    with pytest.raises(ValueError, match="floor=same or event"):
        evaluator_from_spec("lookahead:floor=fast")


@pytest.mark.slow
def test_built_in_floors_on_held_out_seeds_track_the_pymunk_floor():
    """A small sample of the validation (docs/event-floor.md): Eq. 9 on seeds 100-109 of
    the built-in floor, both floors; at this commit r = 0.83, mean gap -1.7 %. The pymunk
    floor against itself with crews 1 % faster correlates 0.86 on 100-139 (the trajectories'
    own sensitivity), so the bound asked here is 0.75."""
    case = cmdp_pymunk.load_case()
    a, b = eq9_on_both_floors(case, range(100, 110), calibration_for(case))
    assert np.corrcoef(a, b)[0, 1] >= 0.75
    assert abs(b.mean() / a.mean() - 1) <= 0.03
