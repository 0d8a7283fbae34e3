"""Floor-plan geometry and the task recipe (``cmdp_pymunk.cases.floorplan``), numbers by hand."""

from cmdp_pymunk.cases import floorplan


def test_side_gap_and_neighbours_by_hand():
    """(0, 0, 2, 2) and (5, 1, 6, 3): y projections share (1, 2), 3 m apart along x; a
    diagonal one shares neither projection; touching edges are a gap of 0, not an overlap."""
    a = floorplan.Rect(0, 0, 2, 2)
    assert a.side_gap(floorplan.Rect(5, 1, 6, 3)) == 3
    assert a.side_gap(floorplan.Rect(3, 3, 4, 4)) is None
    touching = floorplan.Rect(2, 0, 3, 2)
    assert a.side_gap(touching) == 0 and not a.overlaps(touching)
    # a joint between four slabs of a 2 x 2 floor: beside the two in its row only
    rects = [floorplan.Rect.centred(x, y, 2, 2) for x, y in ((-5, 5), (5, 5), (-5, -5), (5, -5))]
    rects.append(floorplan.Rect.centred(0, 5, 2, 1.2))
    assert floorplan.neighbours(rects, 4, [0, 1, 2, 3], 5.0) == [0, 1]
    assert floorplan.neighbours(rects, 4, [0, 1, 2, 3], 2.5) == []  # 3 m apart


def test_overlaps_and_side_gaps_within_the_tolerance_by_hand():
    """(0, 0, 2, 2) and (1.995, 1, 4, 3) meet on x 1.995..2, y 1..2: 0.005 x 1 m, more than
    the 1 mm tolerance; 0.5 mm in is a touch (no overlap; beside it, a gap of 0), and so is
    the 1e-15 m of float noise; a slab 3 m off whose y projection meets a's by 0.5 mm only
    is diagonal to it (None), not beside it."""
    a = floorplan.Rect(0, 0, 2, 2)
    w, h = a.overlap(floorplan.Rect(1.995, 1, 4, 3))
    assert round(w, 9) == 0.005 and h == 1.0
    assert a.overlaps(floorplan.Rect(1.995, 1, 4, 3))
    assert not a.overlaps(floorplan.Rect(1.9995, 1, 4, 3))
    assert a.side_gap(floorplan.Rect(1.9995, 1, 4, 3)) == 0.0
    assert a.side_gap(floorplan.Rect(2 - 1e-15, 0, 4, 2)) == 0.0
    assert floorplan.overlapping_pairs([a, floorplan.Rect(2 - 1e-15, 0, 4, 2)]) == []
    assert a.side_gap(floorplan.Rect(5, 1.9995, 6, 4)) is None


def test_build_tasks_chains_and_joint_ends():
    """A precast P with JC -> HI -> G and a joint J (R -> F) whose R waits for HI on P and on
    Q; Q has no chain (an obstacle), so only HI-P is waited for."""
    tasks = floorplan.build_tasks([("P", "precast"), ("Q", "obstacle"), ("J", "cast-in-place")],
                                  floorplan.PRECAST_RECIPE, {"J": ["P", "Q"]})
    assert [(t["id"], t.get("predecessors", [])) for t in tasks] == [
        ("JC-P", []), ("HI-P", ["JC-P"]), ("G-P", ["HI-P"]), ("R-J", ["HI-P"]),
        ("F-J", ["R-J"])]
    assert tasks[3]["work"] == 0.5 and tasks[3]["material_quantity"] == 0.5
    assert "work" not in tasks[1] and tasks[1]["material_quantity"] == 1.0


def test_recipe_kind_of_prefers_a_predefined_type_and_follows_superclasses():
    recipe = floorplan.Recipe(chains={}, classes={"IfcSlab": "precast",
                                                  "IfcSlab.LANDING": "obstacle"})
    assert recipe.kind_of(["IfcSlabStandardCase", "IfcSlab", "IfcElement"], None) == "precast"
    assert recipe.kind_of(["IfcSlab"], "LANDING") == "obstacle"
    assert recipe.kind_of(["IfcWindow"], None) is None


def test_plan_case_places_the_site_by_hand():
    """A 24 x 26 m plane (half 12 x 13): outlet at x = -12 + 1; crane at y = 13 - 1.5; two
    crews at x = -12 + 2.5, 3 m apart about y = 0; a 3 m high storage on the bottom wall at
    y = -(13 - 1 - 1.5)."""
    import tomllib

    import cmdp_pymunk

    base = tomllib.loads(cmdp_pymunk.BUILTIN_CASE.read_text())
    data = floorplan.plan_case(
        name="n", description="d", half_width_m=12.0, half_height_m=13.0, base=base,
        crane_times={"lift_time_s": 60.0, "assist_time_s": 30.0},
        crews=[("JCC-1", "JCC"), ("HIC-1", "HIC")],
        storages=[floorplan.StorageSpot("S", "struts", 5.0, 3.0, 12.0, 0.6, -1, 2.0)],
        components=[{"id": "P", "kind": "precast", "x_m": 0.0, "y_m": 0.0, "width_m": 2.0,
                     "height_m": 2.0}],
        recipe=floorplan.PRECAST_RECIPE, ends={}, time_limit_s_per_task=30000.0)
    assert data["plane"]["outlet_x_m"] == -11.0 and data["crane"]["y_m"] == 11.5
    assert [(c["start_x_m"], c["start_y_m"]) for c in data["crews"]] == [(-9.5, -1.5),
                                                                          (-9.5, 1.5)]
    assert (data["storages"][0]["x_m"], data["storages"][0]["y_m"]) == (2.0, -10.5)
    assert [t["id"] for t in data["tasks"]] == ["JC-P", "HI-P", "G-P"]
    assert data["simulation"]["max_time_s"] == 90000.0  # 3 tasks x 30,000 s > 80,000 s


def test_narrow_lanes_by_hand():
    """Gaps: a-b 1.0 m (narrower than 2.52), a-c 3.0 m (wide enough), b-d touching (no lane)."""
    a, b = floorplan.Rect(0, 0, 2, 2), floorplan.Rect(3, 0, 5, 2)
    c, d = floorplan.Rect(-5, 0, -3, 2), floorplan.Rect(5, 0, 6, 2)
    assert floorplan.narrow_lanes([a, b, c, d], 2.52) == [(0, 1, 1.0)]


def test_a_lane_with_a_third_rectangle_in_it_is_no_lane():
    from cmdp_pymunk.cases.floorplan import Rect, lane_between, narrow_lanes

    # three 2 m slabs in a row, 0.5 m apart: x 0..2, 2.5..4.5, 5..7; the outer two are 3 m
    # apart, but the middle one stands in that strip: only the two 0.5 m joints are lanes
    row = [Rect(0, 0, 2, 2), Rect(2.5, 0, 4.5, 2), Rect(5, 0, 7, 2)]
    assert narrow_lanes(row, 5.0) == [(0, 1, 0.5), (1, 2, 0.5)]
    assert lane_between(Rect(0, 0, 2, 2), Rect(5, 1, 6, 3)) == Rect(2, 1, 5, 2)
    assert lane_between(Rect(0, 0, 2, 2), Rect(1, 5, 3, 6)) == Rect(1, 2, 2, 5)  # along y
