"""Floor-plan geometry and the task recipe (``cmdp_pymunk.floorplan``), numbers by hand."""

from cmdp_pymunk import floorplan


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
