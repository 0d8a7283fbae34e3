"""One reach rule (issue 41 item 3): the case check asks the simulator's question. A task is
reached when the crew's centre is in its task area (``reach.in_area``, the decision table's
test), over the cells the navigator plans on (``reach.free_cells``). Floors built for it: joints
standing alone between slab rows behind 2 m lanes load and finish; slab edges fenced by beams
are refused by name."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from cmdp_pymunk import BUILTIN_CASE
from cmdp_pymunk.cases.floorplan import PRECAST_RECIPE, Recipe, Step, StorageSpot, plan_case
from cmdp_pymunk.cases.load import CaseError, case_from_dict
from cmdp_pymunk.cases.reach import (
    CLEARANCE_M,
    PlaneGrid,
    centre_clearance,
    fit_distance,
    free_cells,
    in_area,
    regions,
)

FC_RADIUS = math.sqrt(3.2 / math.pi)  # Table 3: 3.2 m2 -> 1.009 m, 2.02 m across
JCC_RADIUS = math.sqrt(4.0 / math.pi)  # 4.0 m2 -> 1.128 m


def _floor(components: list[dict], ends: dict, chains: dict, crews: list, half_w: float,
           half_h: float, name: str) -> dict:
    base = tomllib.loads(BUILTIN_CASE.read_text(encoding="utf-8"))
    storages = [StorageSpot("ST-rebars", "rebars", 6.0, 3.0, 3.0, 0.5, 1, -half_w + 8.0),
                StorageSpot("ST-templates", "templates", 6.0, 3.0, 80.0, 0.5, -1,
                            -half_w + 8.0),
                StorageSpot("ST-struts", "struts", 5.0, 3.0, 12.0, 0.6, 1, half_w - 8.0)]
    return plan_case(name=name, description="", half_width_m=half_w, half_height_m=half_h,
                     base=base, crane_times={"lift_time_s": 240.0, "assist_time_s": 180.0},
                     crews=crews, storages=storages, components=components,
                     recipe=Recipe(chains=chains), ends=ends, time_limit_s_per_task=1000.0)


def isolated_joints(gap_m: float, columns: int = 3) -> dict:
    """Issue 41's floor (b), smaller: two rows of 3 x 2 m slabs (HI -> G) 7 m apart with
    2 x 1.2 m joints between them, and 1.2 x 2 m joints (R -> F) standing alone between the
    rows, ``gap_m`` of open floor above and below each. The rows are walls (their 1 m lanes
    pass no crew), so the middle joint's F area is reached only through a ``gap_m`` lane."""
    xs = [(c - (columns - 1) / 2) * 7.0 for c in range(columns)]
    row_y = 1.0 + gap_m + 1.0
    comps, ends = [], {}
    for r, y in enumerate((row_y, -row_y)):
        comps += [{"id": f"P-{r + 1}{c + 1}", "kind": "precast", "x_m": x, "y_m": y,
                   "width_m": 3.0, "height_m": 2.0} for c, x in enumerate(xs)]
        for c in range(columns - 1):
            jid = f"H-{r + 1}{c + 1}"
            comps.append({"id": jid, "kind": "cast-in-place", "x_m": (xs[c] + xs[c + 1]) / 2,
                          "y_m": y, "width_m": 2.0, "height_m": 1.2})
            ends[jid] = (f"P-{r + 1}{c + 1}", f"P-{r + 1}{c + 2}")
    for c, x in enumerate(xs):
        comps.append({"id": f"V-{c + 1}", "kind": "cast-in-place", "x_m": x, "y_m": 0.0,
                      "width_m": 1.2, "height_m": 2.0})
        ends[f"V-{c + 1}"] = (f"P-1{c + 1}", f"P-2{c + 1}")
    chains = {"precast": (Step("HI", material_quantity=1.0), Step("G")),
              "cast-in-place": PRECAST_RECIPE.chains["cast-in-place"]}
    crews = [("HIC-1", "HIC"), ("GC-1", "GC"), ("RC-1", "RC"), ("FC-1", "FC")]
    return _floor(comps, ends, chains, crews, 16.0, 11.0, f"isolated joints {gap_m:g} m")


def fenced_slabs(corners_open: bool) -> dict:
    """Issue 41's floor (a), smaller: two 4 x 3 m slabs (JC -> HI -> G) side by side, 0.4 m
    beams (R -> F) along every other edge. A slab's JC area (1.2 m round it) reaches 0.8 m
    beyond its beams, less than a JCC's 1.03 m (its radius less the contact solver's slop).
    With ``corners_open`` the top and bottom beams end at the side beams (8.8 m): at the JC
    area's outer corners a JCC's centre stands 1.13 m from the beams' corners; else they run
    10.4 m, across the JC areas' whole width."""
    comps = [{"id": "S-1", "kind": "precast", "x_m": -2.0, "y_m": 0.0, "width_m": 4.0,
              "height_m": 3.0},
             {"id": "S-2", "kind": "precast", "x_m": 2.0, "y_m": 0.0, "width_m": 4.0,
              "height_m": 3.0}]
    long = 8.8 if corners_open else 10.4
    beams = {"B-top": (0.0, 1.7, long, 0.4), "B-bottom": (0.0, -1.7, long, 0.4),
             "B-left": (-4.2, 0.0, 0.4, 3.0), "B-right": (4.2, 0.0, 0.4, 3.0)}
    comps += [{"id": b, "kind": "cast-in-place", "x_m": x, "y_m": y, "width_m": w,
               "height_m": h} for b, (x, y, w, h) in beams.items()]
    ends = {"B-top": ("S-1", "S-2"), "B-bottom": ("S-1", "S-2"), "B-left": ("S-1",),
            "B-right": ("S-2",)}
    crews = [("JCC-1", "JCC"), ("HIC-1", "HIC"), ("GC-1", "GC"), ("RC-1", "RC"), ("FC-1", "FC")]
    return _floor(comps, ends, dict(PRECAST_RECIPE.chains), crews, 12.0, 9.0, "fenced slabs")


def test_in_area_is_one_test_for_a_crew_and_for_the_checks_points():
    # the task area (-1.2, -0.7, 2.2, 0.7): x on its edge counts, 1 mm beyond does not
    area = (-1.2, -0.7, 2.2, 0.7)
    assert in_area(2.2, 0.0, area) and not in_area(2.201, 0.0, area)
    assert not in_area(0.0, -0.701, area)
    xs, ys = np.array([2.2, 2.201, 0.0]), np.array([0.0, 0.0, -0.701])
    assert in_area(xs, ys, area).tolist() == [True, False, False]


def test_the_fc_passes_a_2_m_lane_on_the_navigators_cells_not_a_1_8_m_one():
    """A wall across a 20 x 12 m plane with a gap centred on y = 0.5 (between cell centres
    0.25 and 0.75): the FC's cell centres keep 1.009 - 0.2 = 0.809 m off the wall's ends, so
    a 2.0 m gap (y -0.5..1.5) holds no free centre (0.75 m off); its points 1.0 m off fit
    (1.009 - 0.1 = 0.909 m): a bridge. A 1.8 m gap leaves 0.9 m < 0.909: closed."""
    grid = PlaneGrid.of((10.0, 6.0))
    assert centre_clearance(FC_RADIUS) == pytest.approx(0.809)
    assert fit_distance(FC_RADIUS) == pytest.approx(0.909)
    for gap, connected in ((2.0, True), (1.8, False)):
        walls = [(-0.5, -6.0, 0.5, 0.5 - gap / 2), (-0.5, 0.5 + gap / 2, 0.5, 6.0)]
        centres = regions(grid, ~grid.blocked(walls, FC_RADIUS + CLEARANCE_M))
        assert centres[grid.cell(-5.0, 0.0)[::-1]] != centres[grid.cell(5.0, 0.0)[::-1]]
        labels = regions(grid, free_cells(grid, walls, FC_RADIUS))
        left, right = labels[grid.cell(-5.0, 0.0)[::-1]], labels[grid.cell(5.0, 0.0)[::-1]]
        assert bool(left == right) == connected, gap


def test_cells_are_the_centre_grid_wherever_it_is_connected():
    """No bridge where the centres already join: the navigator plans the built-in floor
    (and every floor whose free centres are one region) exactly as before."""
    from cmdp_pymunk import load_case

    case = load_case(BUILTIN_CASE)
    grid = PlaneGrid.of(case.plane.half_extents)
    rects = [(c.x_m - c.width_m / 2, c.y_m - c.height_m / 2, c.x_m + c.width_m / 2,
              c.y_m + c.height_m / 2) for c in case.components]
    for spec in case.crew_types.values():
        centres = ~grid.blocked(rects, centre_clearance(spec.radius_m))
        assert (free_cells(grid, rects, spec.radius_m) == centres).all()


def test_isolated_joints_behind_2_m_lanes_load_and_finish():
    """The floor the check refused before (every way narrower than 1.62 m) loads; on the
    pymunk floor, priority heuristic (Eq. 9) and the navigator, seed 0 ends every task."""
    from agents.navigator import Navigator
    from cmdp_pymunk.eventfloor.floor import make_floor
    from cmdp_pymunk.rollout import run_episode

    case = case_from_dict(isolated_joints(2.0), "isolated.toml")
    floor = make_floor(case, "pymunk", evaluator="priority")
    episode = run_episode(floor, Navigator(), 0, stall_s=3000.0, progress=False)
    assert episode.stalled is None and episode.makespan_s is not None
    assert floor.site.done


def test_isolated_joints_behind_1_8_m_lanes_are_refused():
    with pytest.raises(CaseError) as err:
        case_from_dict(isolated_joints(1.8), "isolated.toml")
    text = str(err.value)
    assert ("tasks: F-V-2 (F on V-2): no FC crew can reach its work point from where the FC "
            "crews start: every way there is narrower than 1.62 m") in text
    assert "between two components it passes 1.82 m" in text
    assert "fix: widen a joint or lane next to V-2" in text


def test_slab_edges_fenced_by_beams_are_refused_by_name():
    with pytest.raises(CaseError) as err:
        case_from_dict(fenced_slabs(corners_open=False), "fenced.toml")
    text = str(err.value)
    assert "2 problem(s)" in text
    for slab, inside in (("S-1", "S-2, B-top, B-bottom, B-left"),
                         ("S-2", "S-1, B-top, B-bottom, B-right")):
        assert (f"tasks: JC-{slab} (JC on {slab}): no JCC crew can stand in its task area "
                f"({slab} grown by 1.2 m) ({inside} inside it): a JCC crew's centre keeps "
                "1.03 m off components") in text
        assert f"fix: move {inside.replace(', ', ' / ')} clear of {slab}'s edge" in text

@pytest.mark.slow
def test_slab_edges_fenced_but_for_the_corners_load_and_finish():
    """The JCC does reach the JC areas, at their corners: the floor loads and seeds 0-1 end
    every task (pymunk, priority heuristic, the navigator); and seed 41, where JCC-1 came
    along the bottom beam and pressed against it for 4,900 s, 0.3 m short of the area, until
    the navigator closed in on the work point once stuck (``Navigator._work_point``)."""
    from agents.navigator import Navigator
    from cmdp_pymunk.eventfloor.floor import make_floor
    from cmdp_pymunk.rollout import run_episode

    case = case_from_dict(fenced_slabs(corners_open=True), "fenced.toml")
    for seed in (0, 1, 41):
        floor = make_floor(case, "pymunk", evaluator="priority")
        episode = run_episode(floor, Navigator(), seed, stall_s=3000.0, progress=False)
        assert episode.stalled is None and floor.site.done, seed


def test_a_crew_stuck_below_a_beam_closes_in_on_the_work_point_round_its_corner():
    """In the band below the bottom beam the component's nearest point lies behind the beam;
    the nearest work point (the check's: in the JC area, where the JCC fits) lies round the
    beam's corner, 1.13 m or more from it. The navigator heads there once it has backed off
    stuck (the ladder's spots), not before (the golden schedules keep every other approach)."""
    from agents.navigator import Navigator, _Escape
    from cmdp_pymunk.engine import Engine

    case = case_from_dict(fenced_slabs(corners_open=True), "fenced.toml")
    engine = Engine(case, evaluator="priority")
    engine.reset(0)
    plans = Navigator().plans(engine)
    jcc = next(c for c in engine.site.crews if c.type == "JCC")
    task = next(t.index for t in engine.site.tasks if t.id == "JC-S-2")
    jcc.scope = {1: task}  # S-2, the component at index 1
    x, y = 4.02, -3.01  # where seed 41's JCC-1 pressed against the bottom beam
    px, py = plans._work_point(jcc, 1, x, y)
    assert in_area(px, py, engine.site.tasks[task].area)
    assert math.hypot(px - 4.4, py + 1.9) >= fit_distance(JCC_RADIUS) - 1e-9  # the corner
    assert px > 4.4  # round the beam's end, not straight up into it
    assert not plans._stuck_before(jcc, 1)
    plans.escape[jcc.index] = _Escape(1, 0.3, 0.0, spots=[(x, y)])
    assert plans._stuck_before(jcc, 1) and not plans._stuck_before(jcc, 0)
