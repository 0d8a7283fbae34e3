"""A tiny case built in code: a non-square 20 x 12 m plane, three components, four crews.

Component A (precast, left) takes X then K (crane); component B (right) takes X; C (a joint
in the middle) takes M, which needs material "bars" and waits for K on A.

It stays beside the packaged tiny case (``cmdp_pymunk/cases/tiny_floor.toml``, the docs' and
the command-line tests' case, ``cmdp/TinyFloor-v1``) because the unit tests check numbers
worked out by hand on it (a non-square plane, four crew types with round velocities) and edit
it per test through ``tiny_dict()``.
"""

from __future__ import annotations

import copy
import os

import pytest

from cmdp_pymunk.events import Event, EventLog

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")


def pytest_collection_modifyitems(config, items):
    """Tests marked ``nightly`` (the full sweeps, tens of minutes) run only when ``-m`` names
    them (``make test-nightly``): ``pytest -m "not slow"``, ``pytest -m slow`` and a bare
    ``pytest`` leave them out (docs/testing.md)."""
    if "nightly" in (config.getoption("markexpr") or ""):
        return
    nightly = [item for item in items if item.get_closest_marker("nightly")]
    if nightly:
        config.hook.pytest_deselected(items=nightly)
        items[:] = [item for item in items if not item.get_closest_marker("nightly")]

TINY = {
    "case": {"name": "tiny"},
    "plane": {"width_m": 20.0, "height_m": 12.0, "outlet_x_m": -9.0, "outlet_y_m": -4.0,
              "outlet_radius_m": 1.0},
    "simulation": {"max_time_s": 5000.0, "physics_substeps": 2},
    "crane": {"x_m": 0.0, "y_m": 5.5, "lift_time_s": 60.0, "assist_time_s": 30.0},
    "task_types": {
        "X": {"name": "clean", "crew_type": "XC", "area_distance_m": 1.0,
              "congestion_index": 0.5},
        "K": {"name": "hoist", "crew_type": "KC", "area_distance_m": 1.5,
              "congestion_index": 0.4, "needs_crane": True},
        "M": {"name": "reinforce", "crew_type": "MC", "area_distance_m": 1.0,
              "congestion_index": 0.7, "material": "bars"},
    },
    "crew_types": {
        "XC": {"name": "cleaning crew", "duration_mean_min": 2.0, "duration_sd_min": 0.3,
               "occupation_area_m2": 1.0, "velocity_m_s": 1.0, "invasion_index": 0.4},
        "KC": {"name": "hoisting crew", "duration_mean_min": 1.0, "duration_sd_min": 0.0,
               "occupation_area_m2": 1.5, "velocity_m_s": 0.5, "invasion_index": 0.5},
        "MC": {"name": "rebar crew", "work_unit": "m3", "efficiency_mean_per_min": 0.1,
               "efficiency_sd_per_min": 0.0, "occupation_area_m2": 1.0, "velocity_m_s": 0.8,
               "carry_deceleration": 0.9, "invasion_index": 0.25, "carry_capacity": 0.2},
    },
    "materials": {"bars": {"unit": "m3", "acquire_per_min": 0.6, "crane_lift_quantity": 0.5}},
    "crews": [
        {"id": "X-1", "type": "XC", "start_x_m": -6.0, "start_y_m": 3.0},
        {"id": "K-1", "type": "KC", "start_x_m": -6.0, "start_y_m": -3.0},
        {"id": "M-1", "type": "MC", "start_x_m": 6.0, "start_y_m": -3.0},
        {"id": "M-2", "type": "MC", "start_x_m": 6.0, "start_y_m": 3.0},
    ],
    "components": [
        {"id": "A", "kind": "precast", "x_m": -3.0, "y_m": 0.0, "width_m": 2.0, "height_m": 2.0},
        {"id": "B", "kind": "precast", "x_m": 5.0, "y_m": 0.0, "width_m": 2.0, "height_m": 2.0},
        {"id": "C", "kind": "joint", "x_m": 0.5, "y_m": 0.0, "width_m": 1.0, "height_m": 1.0},
    ],
    "storages": [{"id": "S", "material": "bars", "x_m": 6.0, "y_m": 4.5, "width_m": 3.0,
                  "height_m": 2.0, "capacity": 1.0, "congestion_index_full": 0.5}],
    "tasks": [
        {"id": "X-A", "type": "X", "component": "A"},
        {"id": "K-A", "type": "K", "component": "A", "predecessors": ["X-A"]},
        {"id": "X-B", "type": "X", "component": "B"},
        {"id": "M-C", "type": "M", "component": "C", "work": 0.3, "material_quantity": 0.3,
         "predecessors": ["K-A"]},
    ],
}


def distinct_colours(image) -> int:
    """How many colours an RGB(A) image of uint8 shows (alpha left out): each pixel's R, G, B
    packed into one integer, so the count is a 1-D ``np.unique`` (``np.unique(..., axis=0)`` on
    the rows sorted them lexicographically: seconds per chart, more than drawing it)."""
    import numpy as np

    rgb = np.asarray(image)[..., :3].reshape(-1, 3).astype(np.uint32)
    return len(np.unique((rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2]))


def tiny_dict() -> dict:
    return copy.deepcopy(TINY)


REBAR_CREW = 2  # the tiny case's first rebar crew (M-1)


def fetching_env(stock: float, reorder_at: float = 0.0):
    """The tiny case (bars: 0.6 m3/min = 0.01 m3/s, lifts of 0.5 m3 in 60 s, crews carry 0.2)
    with M-1 fetching at the storage holding ``stock`` (``reorder_at``: the bars' reorder
    point, 0 the paper's c7)."""
    import cmdp_pymunk
    from cmdp_pymunk import decide
    from cmdp_pymunk.cases.load import case_from_dict
    from cmdp_pymunk.state import CrewStatus

    data = tiny_dict()
    data["materials"]["bars"]["reorder_at"] = reorder_at
    env = cmdp_pymunk.parallel_env(case=case_from_dict(data, "tiny.toml"), stage=2, seed=0)
    env.reset(seed=0)
    site = env.engine.site
    site.storages[0].stock = stock
    place(env, REBAR_CREW, 6.0, 4.5)
    ctx = decide.Context(site, env.engine.world, env.engine.positions, env.engine.streams, env.log)
    crew = site.crews[REBAR_CREW]
    decide.first_rule(crew, ctx).effect(crew, ctx)  # c5
    assert crew.status == CrewStatus.FETCHING
    return env


def tiny_file_data(**sections) -> dict:
    """The built-in tiny case file's data (``cmdp_pymunk.TINY_CASE``, not ``TINY`` above),
    with ``sections`` put in."""
    import tomllib

    from cmdp_pymunk.cases.load import TINY_CASE

    return {**tomllib.loads(TINY_CASE.read_text()), **sections}


@pytest.fixture
def tiny_case():
    from cmdp_pymunk.cases.load import case_from_dict

    return case_from_dict(tiny_dict(), "tiny.toml")


@pytest.fixture
def tiny_env(tiny_case):
    from cmdp_pymunk import parallel_env

    env = parallel_env(case=tiny_case, stage=2, seed=0)
    env.reset(seed=0)
    return env


def place(env, crew_index: int, x: float, y: float, angle: float = 0.0) -> None:
    """Put a crew somewhere by hand (tests only)."""
    env.engine.world.set_pose(crew_index, x, y, angle)
    env.engine.positions[crew_index] = (x, y)


def run_episode(env, seed: int, controller, max_calls: int = 100000):
    """Run a whole episode; returns the per-call trace (observations, rewards, infos)."""
    obs, infos = env.reset(seed=seed)
    trace = []
    calls = 0
    while env.agents and calls < max_calls:
        obs, rewards, terms, truncs, infos = env.step(controller(env))
        trace.append((env.engine.site.time_s, {a: o.tobytes() for a, o in obs.items()}, rewards,
                      {a: i["elapsed_s"] for a, i in infos.items()}))
        calls += 1
    return trace


# A whole little run's event log worked out by hand on the tiny case above (media and schedule
# tests draw from it): X-1 cleans A then B and leaves;
# K-1 waits for X-A, then hoists A (waiting for the crane first) and leaves; M-1 fetches bars,
# reinforces C with one pause to fetch more, and is still walking out when the log ends at
# 540 s; M-2 never gets work and leaves at 540 s.
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


def make_log(rows=RUN) -> EventLog:
    log = EventLog()
    for t, kind, crew, subject in rows:
        log.add(t, kind, crew, subject)
    return log


def make_events(rows=RUN) -> list[Event]:
    return make_log(rows).events


def scripted_floor(evaluator="priority", case=None, seed: int = 0):
    """The built-in (or given) floor with the scripted navigator as ``cmdp-simulate`` runs it
    (idle crews parked, no rays), reset: (env, navigator)."""
    import cmdp_pymunk
    from agents.specs import make_navigator

    env = cmdp_pymunk.parallel_env(case=case, seed=seed, evaluator=evaluator, park_idle=True,
                                   blind=True, stall_s=3600.0)
    navigator = make_navigator("scripted", env.engine)
    env.reset(seed=seed)
    navigator.reset(seed)
    return env, navigator


def play(env, navigator, until_s: float | None = None):
    """Step the floor to its end (or to ``until_s``); returns the env."""
    while env.agents and (until_s is None or env.engine.site.time_s < until_s):
        env.step(env.agent_actions(navigator, None))
    return env


def play_floor(evaluator="priority", case=None, seed: int = 0):
    """A whole floor under ``evaluator`` with the scripted navigator; returns the env."""
    return play(*scripted_floor(evaluator, case, seed))


def event_floor(evaluator="priority", seed: int = 0):
    """The built-in case's event floor played to its end under ``evaluator`` (milliseconds:
    the tests of an evaluator's choices need no per-second physics)."""
    import cmdp_pymunk
    from cmdp_pymunk.evaluate import make_evaluator
    from cmdp_pymunk.eventfloor import EventFloor, calibration_for

    case = cmdp_pymunk.load_case(None)
    floor = EventFloor(case, evaluator=make_evaluator(evaluator), stall_s=3600.0,
                       calibration=calibration_for(case))
    floor.reset(seed)
    floor.run()
    return floor


@pytest.fixture(scope="session")
def priority_floor():
    """The built-in case's event floor, seed 0, played once per session under the priority
    heuristic (``event_floor()``), for the tests that compare another evaluator's floor with
    it and only read it (its log, its makespan)."""
    return event_floor()
