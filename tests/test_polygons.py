"""Polygon components (issue 41 item 2): the case format, the reach rule, the grid, the physics,
the walks and the renderer, against points worked out by hand.

The tiny case (a non-square 20 x 12 m plane) with component A an L instead of its 2 x 2 box:

    y
    2  +--+                    the L: the vertical arm x -5..-4, y -2..2, and the
       |  |   notch            bottom arm x -5..-1, y -2..-1; its box is (-5, -2, -1, 2),
   -1  |  +--------+           so the notch x -4..-1, y -1..2 lies in the box, not the L.
   -2  +-----------+
      -5 -4       -1  x

X (area distance 1 m) and K (1.5 m) are its tasks. An XC crew has radius sqrt(1/pi) = 0.564 m.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import tiny_dict

from cmdp_pymunk import geometry
from cmdp_pymunk.cases.load import CaseError, case_from_dict
from cmdp_pymunk.cases.reach import PlaneGrid, Reach, free_cells, in_area, unreachable
from cmdp_pymunk.geometry import Outline, contains, grown, outline, outline_problems
from cmdp_pymunk.state import Site, inside

L_CW = [(-5, -2), (-5, 2), (-4, 2), (-4, -1), (-1, -1), (-1, -2)]  # clockwise, as drawn
XC_RADIUS = math.sqrt(1.0 / math.pi)  # 0.5642 m


def l_dict() -> dict:
    data = tiny_dict()
    a = data["components"][0]
    assert a["id"] == "A"
    data["components"][0] = {"id": "A", "kind": "precast",
                             "outline": [list(p) for p in L_CW]}
    return data


@pytest.fixture(scope="module")
def l_case():
    return case_from_dict(l_dict())


# -- the case format -----------------------------------------------------------------------------

def test_an_outline_is_stored_counter_clockwise_and_its_box_is_the_rectangle(l_case):
    a = l_case.components[0]
    # the box of the L: x -5..-1, y -2..2 -> centre (-3, 0), 4 x 4
    assert (a.x_m, a.y_m, a.width_m, a.height_m) == (-3.0, 0.0, 4.0, 4.0)
    pts = np.array(a.outline)
    signed = 0.5 * np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1])
    assert signed == pytest.approx(7.0)  # 4 x 1 + 1 x 3, positive: counter-clockwise
    assert set(map(tuple, a.outline)) == {tuple(map(float, p)) for p in L_CW}
    assert tuple(a.shape) == (-5.0, -2.0, -1.0, 2.0) and isinstance(a.shape, Outline)
    # a rectangle dumps as before outlines existed (fingerprints unchanged)
    assert "outline" not in l_case.components[1].model_dump()


@pytest.mark.parametrize("points, words", [
    ([[0, 0], [1, 1]], "at least 3"),
    ([[-5, -2], [-4, -1], [-5, -1], [-4, -2]], "cross"),  # a bow tie
    ([[-5, -2], [-4, -2], [-3, -2]], "no area"),
])
def test_a_bad_outline_is_refused_naming_the_entry_and_the_fix(points, words):
    data = l_dict()
    data["components"][0]["outline"] = points
    with pytest.raises(CaseError) as err:
        case_from_dict(data)
    text = str(err.value)
    assert "components" in text and words in text and "fix" in text


def test_a_rectangle_that_disagrees_with_the_outline_is_refused():
    data = l_dict()
    data["components"][0]["width_m"] = 3.0  # the L's box is 4 m wide
    with pytest.raises(CaseError, match="width_m disagree with the outline's bounding box"):
        case_from_dict(data)


def test_components_overlap_by_their_polygons_not_their_boxes():
    data = l_dict()
    # a 1 x 1 component in the notch: inside the L's box, clear of the L -> no overlap
    data["components"].append({"id": "N", "x_m": -2.0, "y_m": 1.0, "width_m": 1.0,
                               "height_m": 1.0})
    assert case_from_dict(data).components[-1].id == "N"
    data["components"][-1]["y_m"] = -0.8  # now y -1.3..-0.3: 0.3 m into the bottom arm
    with pytest.raises(CaseError, match="overlaps"):
        case_from_dict(data)


# -- geometry --------------------------------------------------------------------------------------

def test_a_rectangle_grows_to_the_same_rectangle_and_an_l_by_its_edges():
    assert grown((-4.0, -1.0, -2.0, 1.0), 1.5) == (-5.5, -2.5, -0.5, 2.5)
    area = grown(outline(L_CW), 1.0)
    # mitred: every corner of the L moves 1 m out along both its edges; the reflex corner
    # (-4, -1) moves in to (-3, 0)
    assert set(area.points) == {(-6.0, -3.0), (0.0, -3.0), (0.0, 0.0), (-3.0, 0.0),
                                (-3.0, 3.0), (-6.0, 3.0)}


def test_outline_problems_accepts_a_triangle():
    assert outline_problems([(0, 0), (2, 0), (0, 1)]) == []


# -- the reach rule, both ways -----------------------------------------------------------------

def test_the_reach_rule_takes_the_polygon_of_a_task_area(l_case):
    site = Site(l_case, 2)
    x_a = next(t for t in site.tasks if t.id == "X-A")
    area = x_a.area  # the L grown by 1 m: its box (-6, -3, 0, 3)
    assert tuple(area) == (-6.0, -3.0, 0.0, 3.0)
    # (-2, 1): in the box, but 2 m from the L (to x = -4 and to y = -1): not reached
    assert not in_area(-2.0, 1.0, area) and not inside(-2.0, 1.0, area)
    # (-2, -0.2): 0.8 m above the bottom arm's top edge y = -1: reached
    assert in_area(-2.0, -0.2, area) and inside(-2.0, -0.2, area)
    # (-3.2, 0.5): 0.8 m right of the vertical arm's edge x = -4: reached
    assert in_area(-3.2, 0.5, area)
    # on the area's edge (0, -3) and its reflex corner (-3, 0): edges included
    assert in_area(0.0, -3.0, area) and in_area(-3.0, 0.0, area)
    # the vectorised test gives the same answers
    got = in_area(np.array([-2.0, -2.0, -3.2]), np.array([1.0, -0.2, 0.5]), area)
    assert got.tolist() == [False, True, True]


def test_the_decision_table_reaches_in_the_notch_and_not_beyond_the_area(l_case):
    from cmdp_pymunk import decide
    from cmdp_pymunk.state import TASKS

    site = Site(l_case, 2)
    crew = site.crews[0]  # X-1, an XC crew
    x_a = next(t for t in site.tasks if t.id == "X-A")
    crew.scope_kind, crew.scope = TASKS, {x_a.component: x_a.index}

    class Ctx:  # what reached_target reads
        reached: dict = {}

    ctx = Ctx()
    ctx.site = site
    for (x, y), want in (((-2.0, -0.2), x_a.component), ((-2.0, 1.0), -1)):
        ctx.reached, ctx.positions = {}, {crew.index: (x, y)}
        assert decide.reached_target(crew, ctx) == want


def test_task_areas_conflict_by_their_polygons():
    data = l_dict()
    # component D in the notch: x -2..-1, y 1..2
    data["components"].append({"id": "D", "x_m": -1.5, "y_m": 1.5, "width_m": 1.0,
                               "height_m": 1.0})
    data["tasks"].append({"id": "X-D", "type": "X", "component": "D"})
    site = Site(case_from_dict(data), 2)
    by_id = {t.id: t for t in site.tasks}
    # D's X area: x -3..0, y 0..3; the L's X area reaches (-3, 0)..(-3, 3) and (0, 0): the
    # two only touch along x = -3 and y = 0 -> no conflict, though their boxes overlap
    assert by_id["X-D"].index not in by_id["X-A"].conflicts
    # the L's K area (1.5 m: reflex corner at (-2.5, 0.5)) reaches 0.5 m into D's area
    assert by_id["X-D"].index in by_id["K-A"].conflicts


# -- the grid -------------------------------------------------------------------------------------

def test_the_grid_blocks_cells_by_the_polygon(l_case):
    grid = PlaneGrid.of(l_case.plane.half_extents)  # 40 x 24 cells of 0.5 m
    shape = l_case.components[0].shape
    blocked = grid.blocked([shape], XC_RADIUS - 0.2)  # centre clearance 0.364 m

    def at(x, y):  # the cell of centre (x, y): column (x + 10) / 0.5 - 0.5
        return blocked[int((y + 6) / 0.5 - 0.5), int((x + 10) / 0.5 - 0.5)]

    assert at(-4.25, 0.25)  # inside the vertical arm
    assert at(-2.25, -1.25)  # inside the bottom arm
    assert not at(-2.25, 0.75)  # the notch: 1.75 m from x = -4 and from y = -1
    assert at(-3.75, 0.25)  # 0.25 m right of x = -4: closer than 0.364
    assert not at(-3.25, 0.25)  # 0.75 m right of x = -4, 1.25 m above y = -1
    # the box would have blocked the notch cell
    assert grid.blocked([tuple(shape)], XC_RADIUS - 0.2)[13, 15]
    free = free_cells(grid, [shape], XC_RADIUS)
    assert free[13, 15] and not free[12, 11]


def test_a_work_point_in_the_notch_is_reached(l_case):
    reach = Reach(l_case)
    k = next(i for i, t in enumerate(l_case.tasks) if t.id == "X-A")
    fits = reach.fits_in_area(XC_RADIUS, k)
    # cell (-2.25, -0.25) [column 15, row 11]: 0.75 m above y = -1, inside the 1 m area, and
    # more than the fit distance 0.464 m off the L -> a point there where the crew fits
    assert fits[11, 15]
    # cell (-2.25, 1.25) [row 14]: 2.25 m from the L, outside the area
    assert not fits[14, 15]
    assert unreachable(l_case) == []


# -- physics ---------------------------------------------------------------------------------------

def test_a_crew_driven_into_the_notch_stops_at_the_outline(l_case):
    from cmdp_pymunk.world import World

    site = Site(l_case, 2)
    world = World(l_case, site)
    assert len(world.component_shapes[0]) >= 2  # the L in convex pieces
    body = world.bodies[0]  # X-1, radius 0.564
    body.position = (-2.0, 1.0)  # in the notch: inside the box, clear of the L
    world.drive(0, -1.0, 0.0, 0.0)  # west, 1 m/s, towards the vertical arm's edge x = -4
    for _ in range(5):
        world.step(1.0, l_case.simulation.physics_substeps)
    x, y = world.pose(0)[:2]
    # stopped against x = -4: its centre at -4 + 0.564, give or take the contact slop (0.1)
    assert -4.0 + XC_RADIUS - 0.11 <= x <= -4.0 + XC_RADIUS + 0.01
    assert y == pytest.approx(1.0, abs=0.05)
    world.drive(0, 0.0, -1.0, 0.0)  # south, towards the bottom arm's top edge y = -1
    for _ in range(5):
        world.step(1.0, l_case.simulation.physics_substeps)
    x, y = world.pose(0)[:2]
    assert -1.0 + XC_RADIUS - 0.11 <= y <= -1.0 + XC_RADIUS + 0.01


def test_a_polygon_task_area_is_a_sensor_of_its_polygon(l_case):
    from cmdp_pymunk.world import World

    site = Site(l_case, 2)
    world = World(l_case, site)
    x_a = next(t for t in site.tasks if t.id == "X-A")
    world.add_task_area(x_a.index, x_a.area)
    shapes = world.area_shapes[x_a.index]
    assert all(s.sensor for s in shapes)

    def hit(x, y):
        return any(s.point_query((x, y)).distance <= 0 for s in shapes)

    assert hit(-2.0, -0.2) and hit(-3.2, 0.5) and not hit(-2.0, 1.0)
    world.remove_task_area(x_a.index)
    assert x_a.index not in world.area_shapes
    assert not any(getattr(s, "kind", None) == 3 and getattr(s, "task", -1) == x_a.index
                   for s in world.space.shapes)


# -- render ---------------------------------------------------------------------------------------

def test_the_renderer_draws_the_polygon_not_its_box(l_case):
    from cmdp_pymunk.engine import Engine
    from media import render

    engine = Engine(l_case, evaluator="priority")
    engine.reset(seed=0)
    frame = render.draw_frame(engine)
    colour = np.array(render.component_colour(engine.site, 0), dtype=np.uint8)

    def pixel(x, y):
        col, row = render.world_to_pixel(engine, x, y)
        return frame[row, col]

    assert (pixel(-4.5, 1.0) == colour).all()  # the vertical arm
    assert (pixel(-2.0, -1.5) == colour).all()  # the bottom arm
    assert not (pixel(-2.0, 1.0) == colour).all()  # the notch (in the box)


# -- whole floors ----------------------------------------------------------------------------

@pytest.mark.parametrize("fidelity", ["pymunk", "event"])
def test_the_l_floor_runs_to_the_end(l_case, fidelity):
    from agents.navigator import Navigator
    from cmdp_pymunk.eventfloor import make_floor
    from cmdp_pymunk.rollout import run_episode

    floor = make_floor(l_case, fidelity, evaluator="priority", park_idle=True,
                       max_time_s=5000.0)
    episode = run_episode(floor, Navigator(), 0, 1200.0, progress=False)
    assert episode.makespan_s is not None and episode.stalled is None


def test_an_outline_survives_pickling_as_its_polygon():
    import copy
    import pickle

    shape = outline(L_CW)
    assert pickle.loads(pickle.dumps(shape)) == shape
    assert copy.deepcopy(shape).points == shape.points
    assert shape != outline([(-5, -2), (-1, -2), (-1, 2), (-5, 2)])  # same box, not equal
    assert contains(shape, -4.5, 1.0) and not contains(shape, -2.0, 1.0)
    assert geometry.overlap(shape, (-3.0, 0.0, -2.0, 1.0)) is False
