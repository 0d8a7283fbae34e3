"""The scripted navigator's planning: regression tests for the stalls it caused."""

import math

import numpy as np
import pytest

from agents.navigator import Navigator


def test_carrot_out_of_a_blocked_cell_takes_the_free_cell_lowest_on_the_field(tiny_env):
    """Seed 102 (built-in case): FC-1 was squeezed into a blocked cell against a component's
    corner; the nearest free cell lay on the lane a parked crew blocked (a detour field prices
    it at 1e4), an equally near one on the free lane beside it. Heading for the first kept it
    pushing into the parked crew for 3,000 s."""
    nav = Navigator().plans(tiny_env.engine)  # this episode's grid and fields
    field = np.full((nav.ny, nav.nx), 50.0)
    i, j = nav._cell(0.1, 0.1)
    field[j, i] = math.inf                 # the crew's own cell: blocked
    field[j, i - 1] = math.inf
    field[j - 1, i] = math.inf
    field[j, i + 1] = 1e4                  # first in scan order: behind the parked crew
    field[j + 1, i] = 12.0                 # as near, and on the free lane
    x, y = nav._carrot(field, 0.1, 0.1, lowest=True)  # on a detour
    assert (x, y) == (pytest.approx(nav.cx[0, i]), pytest.approx(nav.cy[j + 1, 0]))
    x, y = nav._carrot(field, 0.1, 0.1)  # on its own field: the nearest, as before
    assert (x, y) == (pytest.approx(nav.cx[0, i + 1]), pytest.approx(nav.cy[j, 0]))


def test_carrot_prefers_nearer_ring_over_lower_value(tiny_env):
    nav = Navigator().plans(tiny_env.engine)
    field = np.full((nav.ny, nav.nx), math.inf)
    i, j = nav._cell(0.1, 0.1)
    field[j, i + 1] = 40.0                 # ring 1
    field[j, i - 2] = 1.0                  # ring 2: lower, but farther
    x, y = nav._carrot(field, 0.1, 0.1, lowest=True)
    assert (x, y) == (pytest.approx(nav.cx[0, i + 1]), pytest.approx(nav.cy[j, 0]))


@pytest.mark.slow
def test_seed_102_finishes_with_priority_and_scripted_navigator(tmp_path):
    """The whole episode that stalled at t = 41,461 s before the fix."""
    from training.commands import simulate

    out = tmp_path / "s102"
    assert simulate.main(["--seed", "102", "--out", str(out), "--no-charts",
                          "--no-progress"]) == 0


def lane_floor(way_round: bool = True):
    """A floor built to wedge a crew: a wall splits a 24 x 30 m plane, with a 1.8 m lane near
    the bottom and a 3 m gap at the top. X-1 (0.3 m/s) walks from the left to R on the right;
    Y-1 stands parked in the lane (its task waits for X-1's). Re-planning round Y-1 for 40
    steps (12 m) walks X-1 up the wall, and then its own field, shorter through the lane,
    leads it back: it paces between the two for ever. The way round the top is about 50 m.
    Without ``way_round`` the wall closes the top too: the lane is the only way, and Y-1
    waits there for the task X-1 cannot reach (a deadlock but for Y-1 making way)."""
    from conftest import tiny_dict

    from cmdp_pymunk.cases.load import case_from_dict

    d = tiny_dict()
    cleaning = d["task_types"]["X"]
    d["plane"] = {"width_m": 24.0, "height_m": 30.0, "outlet_x_m": -10.0, "outlet_y_m": 13.0,
                  "outlet_radius_m": 1.0}
    d["task_types"] = {"X": cleaning, "Y": dict(cleaning, crew_type="YC", name="wipe")}
    d["crew_types"] = {"XC": dict(d["crew_types"]["XC"], velocity_m_s=0.3),
                       "YC": dict(d["crew_types"]["XC"], name="wiping crew")}
    d["crews"] = [{"id": "X-1", "type": "XC", "start_x_m": -6.0, "start_y_m": -10.0},
                  {"id": "Y-1", "type": "YC", "start_x_m": 0.0, "start_y_m": -10.0}]
    # the wall at x = 0: y -15 to -10.9 and -9.1 to 12 (the lane between, the gap above)
    d["components"] = [
        {"id": "W1", "kind": "precast", "x_m": 0.0, "y_m": -12.95, "width_m": 1.0,
         "height_m": 4.1},
        {"id": "W2", "kind": "precast", "x_m": 0.0, "y_m": 1.45 if way_round else 2.95,
         "width_m": 1.0, "height_m": 21.1 if way_round else 24.1},
        {"id": "R", "kind": "precast", "x_m": 7.0, "y_m": -10.0, "width_m": 1.0,
         "height_m": 1.0}]
    d["tasks"] = [{"id": "X-R", "type": "X", "component": "R"},
                  {"id": "Y-R", "type": "Y", "component": "R", "predecessors": ["X-R"]}]
    d["storages"], d["materials"] = [], {}
    return case_from_dict(d, "lane.toml")


def play_lane(stall_s: float = 1200.0, way_round: bool = True):
    from cmdp_pymunk.engine import Engine
    from cmdp_pymunk.rollout import run_episode

    engine = Engine(lane_floor(way_round), evaluator="priority", park_idle=True,
                    max_time_s=5000.0)
    navigator = Navigator()
    episode = run_episode(engine, navigator, 0, stall_s, progress=False)
    return engine, navigator, episode


def test_the_ladder_gets_a_crew_out_of_the_lane_it_paces_at():
    engine, navigator, episode = play_lane()
    assert episode.stalled is None and engine.site.done
    rungs = navigator.plans(engine).rungs
    assert rungs["back_off"] >= 1 and rungs["detour"] >= 1  # it took the way round the top
    # the same floor twice: the same schedule (no random generator in the ladder)
    again, _, _ = play_lane()
    assert [e for e in again.log.events] == [e for e in engine.log.events]


def test_without_the_ladder_the_crew_paces_until_the_stall_guard(monkeypatch):
    """The floor does wedge the first rule alone (the navigator before the ladder)."""
    import agents.navigator as nav

    monkeypatch.setattr(nav, "BACK_OFF_AFTER_S", math.inf)
    engine, navigator, episode = play_lane(stall_s=900.0)
    assert episode.stalled is not None and not engine.site.done
    assert engine.site.crews[0].status == 0  # X-1 still reaching


def test_a_parked_crew_in_the_only_lane_is_asked_to_make_way():
    """The lane is the only way and Y-1, parked in it, waits for X-1's task: the imported
    L-shaped storey's deadlock (nearest, seed 1: a parked GC-1 at the corner that JCC-1 and
    HIC-1 had to pass, stalled at 16,747 s). Backing off, X-1 asks Y-1 aside
    (``Engine.make_way``), and both tasks end."""
    engine, navigator, episode = play_lane(way_round=False)
    assert episode.stalled is None and engine.site.done
    assert navigator.plans(engine).rungs["make_way"] >= 1


def test_giving_up_walks_to_a_free_cell_drawn_from_crew_and_time(tiny_env):
    """Rung 4 draws its cell from the crew's index and the time alone: two plans of the same
    floor at the same second pick the same cell; it lies 4-12 m off, free, off the crews."""
    from agents.navigator import _Escape

    engine = tiny_env.engine
    picks = []
    for _ in range(2):
        plans = Navigator().plans(engine)
        crew = engine.site.crews[0]
        x, y, _ = engine.pose(0)
        esc = _Escape(target=0, best=10.0, since_s=0.0, rung=2)
        plans._give_up_this_way(crew, esc, x, y, engine.site.time_s)
        field, until_s, fresh = esc.retreat
        j, i = np.unravel_index(np.argmin(field), field.shape)
        picks.append((i, j))
        assert fresh and until_s > engine.site.time_s
        assert 4.0 <= math.hypot(plans.cx[0, i] - x, plans.cy[j, 0] - y) <= 12.0
        assert not plans.crew_grid[0].blocked[j, i]
    assert picks[0] == picks[1]


def test_way_walks_down_the_field_to_the_target(tiny_env):
    engine = tiny_env.engine
    navigator = Navigator()
    navigator.actions(engine)
    for i, crew in enumerate(engine.site.crews):
        path = navigator.way(engine, i)
        if crew.moving and crew.values:
            x, y, _ = engine.pose(i)
            assert path[0] == (pytest.approx(x), pytest.approx(y)) and len(path) >= 2
            tx, ty = engine.site.target_xy[max(crew.values, key=crew.values.get)]
            assert math.dist(path[-1], (tx, ty)) < math.dist(path[0], (tx, ty))
        else:
            assert path == []


def test_the_ladder_clock_restarts_where_the_crew_reaches_and_after_a_gap(tiny_env,
                                                                          monkeypatch):
    """A crew waiting where it reaches its target, or not asked for an action for a while (an
    idle jump), is not stuck: the imported slabs-on-beams floor had backed off a hoisting crew
    waiting at its slab. One in the approach band but outside the task area is: there
    progress is closing in on the area."""
    from agents.navigator import BACK_OFF_AFTER_S, _Escape

    engine = tiny_env.engine
    plans = Navigator().plans(engine)
    crew = engine.site.crews[0]  # X-1, heading for A (component 0)
    x, y, _ = engine.pose(0)
    now = engine.site.time_s
    away = np.full((plans.ny, plans.nx), 20.0)
    band = np.zeros((plans.ny, plans.nx))  # its own field says: in the approach band
    for reached, last_s in ((True, now - 1.0), (False, now - 60.0)):
        monkeypatch.setattr(plans, "_reached", lambda *args, r=reached: r)
        esc = plans.escape[0] = _Escape(0, 20.0, now - 10 * BACK_OFF_AFTER_S, away,
                                        last_s=last_s)
        assert plans._escalate(crew, 0, band, x, y) is None
        assert esc.since_s == now and esc.rung == 0 and esc.retreat is None
    # asked every second, in the band but not in the area, no progress for long: it backs off
    esc = plans.escape[0] = _Escape(0, 20.0, now - BACK_OFF_AFTER_S, away, last_s=now - 1.0)
    plans._escalate(crew, 0, band, x, y)
    assert esc.rung == 1 and esc.spots == [(x, y)]


def test_reached_is_the_decision_tables_region(tiny_env):
    """``_reached``: inside the task area of a component target (A at (-3, 0), 2 x 2 m,
    cleaning area distance 1 m: x -5..-1, y -2..2), a storage's rectangle (S: x 4.5..7.5,
    y 3.5..5.5), the outlet's circle ((-9, -4), 1 m)."""
    engine = tiny_env.engine
    plans = Navigator().plans(engine)
    crew = engine.site.crews[0]
    crew.scope = {0: 0}  # A -> X-A
    assert plans._reached(crew, 0, -4.9, 1.9) and not plans._reached(crew, 0, -5.1, 0.0)
    storage = len(engine.site.components)
    assert plans._reached(crew, storage, 7.4, 3.6) and not plans._reached(crew, storage, 4.4, 4)
    outlet = engine.site.outlet_target
    assert plans._reached(crew, outlet, -9.0, -3.1) and not plans._reached(crew, outlet, -9, -2.9)


def test_a_grids_weighted_graph_is_scipys_from_its_edges():
    """``_Grid._weighted`` lays new weights into the edges' CSR layout found once: the same
    matrix, entry for entry, as ``csr_matrix((w, (src, dst)))`` sorting them each time."""
    from scipy.sparse import csr_matrix

    from agents.navigator import _Grid
    from cmdp_pymunk.cases.reach import PlaneGrid

    rng = np.random.default_rng(3)
    plane = PlaneGrid.of((6.0, 4.0), 0.5)
    grid = _Grid.__new__(_Grid)
    grid.src, grid.dst, grid.length = plane.edges(rng.random((plane.ny, plane.nx)) > 0.2)
    grid.n, grid._layout = plane.nx * plane.ny, None
    for _ in range(3):
        w = grid.length * rng.uniform(1.0, 5.0, len(grid.length))
        ours, scipys = grid._weighted(w), csr_matrix((w, (grid.src, grid.dst)),
                                                     shape=(grid.n, grid.n))
        assert (ours.indptr == scipys.indptr).all() and (ours.indices == scipys.indices).all()
        assert (ours.data == scipys.data).all()
