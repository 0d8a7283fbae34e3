"""The IFC importer and the 4D export (``cmdp_pymunk.cases.ifc_import`` and ``ifc_export``,
``cmdp-import-ifc``, ``cmdp-simulate --ifc``) on models built in the test with ``ifcopenshell.api``
(``tests/ifc_models.py``). Skipped without the [ifc] extra."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

ifcopenshell = pytest.importorskip("ifcopenshell")

from cmdp_pymunk.cases.ifc_export import read_4d  # noqa: E402
from cmdp_pymunk.cases.ifc_import import import_storey  # noqa: E402
from cmdp_pymunk.cases.ifc_overlay import load_overlay  # noqa: E402
from cmdp_pymunk.cases.load import CaseError, load_case  # noqa: E402
from tests import ifc_models  # noqa: E402
from training.commands import import_ifc, simulate  # noqa: E402


@pytest.fixture(scope="module", params=["IFC4", "IFC2X3"])
def two_by_two(request, tmp_path_factory):
    f, elements = ifc_models.two_by_two(request.param)
    path = tmp_path_factory.mktemp(request.param) / "floor.ifc"
    f.write(str(path))
    return path, {n: e.GlobalId for n, e in elements.items()}


def test_two_by_two_components_by_hand(two_by_two):
    path, guids = two_by_two
    data, report = import_storey(path, "Level 1")
    comps = {c["id"]: c for c in data["components"]}
    # the floor spans x 99..111, y 49..61: its centre (105, 55) is the origin
    assert {k: (c["kind"], c["x_m"], c["y_m"], c["width_m"], c["height_m"])
            for k, c in comps.items()} == {
        "S-11": ("precast", -5.0, 5.0, 2.0, 2.0), "S-12": ("precast", 5.0, 5.0, 2.0, 2.0),
        "S-21": ("precast", -5.0, -5.0, 2.0, 2.0), "S-22": ("precast", 5.0, -5.0, 2.0, 2.0),
        "B-H1": ("cast-in-place", 0.0, 5.0, 2.0, 1.2),
        "B-H2": ("cast-in-place", 0.0, -5.0, 2.0, 1.2),
        "B-V1": ("cast-in-place", -5.0, 0.0, 1.2, 2.0),
        "B-V2": ("cast-in-place", 5.0, 0.0, 1.2, 2.0)}
    assert {k: c["ifc_guid"] for k, c in comps.items()} == guids
    # plane: 12 x 12 m of components plus the default margins 6 (x) and 7 (y) on each side
    assert data["plane"]["width_m"] == 24.0 and data["plane"]["height_m"] == 26.0
    assert data["plane"]["outlet_x_m"] == -11.0
    assert report.components_by_class == {"IfcSlab": 4, "IfcBeam": 4}
    assert report.skipped_by_class == {"IfcWindow": 1}
    assert report.precedences == "recipe"


def test_two_by_two_tasks_and_precedences_by_hand(two_by_two):
    data, report = import_storey(two_by_two[0], "Level 1")
    preds = {t["id"]: t.get("predecessors", []) for t in data["tasks"]}
    # 4 slabs x (JC, HI, G) + 4 beams x (R, F) = 20; R waits for HI on the slabs it joins,
    # listed top row first, then left to right
    assert report.tasks == len(preds) == 20
    assert preds["JC-S-11"] == [] and preds["HI-S-11"] == ["JC-S-11"]
    assert preds["G-S-22"] == ["HI-S-22"]
    assert preds["R-B-H1"] == ["HI-S-11", "HI-S-12"]
    assert preds["R-B-H2"] == ["HI-S-21", "HI-S-22"]
    assert preds["R-B-V1"] == ["HI-S-11", "HI-S-21"]
    assert preds["R-B-V2"] == ["HI-S-12", "HI-S-22"]
    assert preds["F-B-V2"] == ["R-B-V2"]
    tasks = {t["id"]: t for t in data["tasks"]}
    assert tasks["HI-S-11"]["material_quantity"] == 1.0  # a strut set per slab
    assert (tasks["R-B-H1"]["work"], tasks["F-B-H1"]["work"]) == (0.5, 12.0)
    # seven crews as the built-in case, in the left margin, 3 m apart, centred on y = 0
    assert [c["id"] for c in data["crews"]] == ["JCC-1", "HIC-1", "GC-1", "RC-1", "RC-2",
                                                "FC-1", "FC-2"]
    assert [c["start_y_m"] for c in data["crews"]] == [-9.0, -6.0, -3.0, 0.0, 3.0, 6.0, 9.0]
    assert {c["start_x_m"] for c in data["crews"]} == {-9.5}


@pytest.mark.parametrize("schema", ["IFC4", "IFC2X3"])
def test_the_command_writes_a_case_that_simulates_and_exports_4d(tmp_path, capsys, schema):
    """Import, simulate to the end, export 4D, read the tasks back: each task's start and
    finish are simulated second 0 (--ifc-start) plus its schedule.csv times, to the second;
    its element and its crew are the case's. IFC4 keeps them in IfcTaskTime, IFC2X3 in an
    IfcScheduleTimeControl (IfcRelAssignsTasks)."""
    f, elements = ifc_models.two_by_two(schema)
    model = tmp_path / "floor.ifc"
    f.write(str(model))
    case_file = tmp_path / "floor.toml"
    assert import_ifc.main([str(model), "--storey", "Level 1", "--out", str(case_file)]) == 0
    out = capsys.readouterr().out
    assert "8 components (4 IfcBeam, 4 IfcSlab), 20 tasks, 7 crews" in out
    assert "skipped (not in the recipe): 1 IfcWindow" in out
    case = load_case(case_file)
    assert len(case.tasks) == 20
    run = tmp_path / "run"
    assert simulate.main(["--case", str(case_file), "--out", str(run), "--no-charts",
                          "--no-progress", "--ifc", str(model),
                          "--ifc-start", "2026-03-02T07:00:00"]) == 0
    # the console names the 4D file and where its dates come from
    assert "4D model (IFC) floor-4d.ifc, elapsed time from 2026-03-02 07:00:00" in \
        capsys.readouterr().out
    rows = (run / "schedule.csv").read_text().splitlines()[1:]
    assert len(rows) == 20 and all(r.split(",")[6] == "true" for r in rows)  # to the end
    import json

    assert json.loads((run / "summary.json").read_text())["tasks_finished"] == 20
    sim = {r.split(",")[0]: r.split(",") for r in rows}
    tasks = {t["id"]: t for t in read_4d(run / "floor-4d.ifc")}
    assert set(tasks) == set(sim)
    import datetime

    t0 = datetime.datetime(2026, 3, 2, 7, 0, 0)

    def at(seconds: str) -> str:  # whole seconds, as the export writes them
        return (t0 + datetime.timedelta(seconds=float(seconds))).isoformat(timespec="seconds")

    for task_id, (_, crew, start_s, end_s, *_rest) in sim.items():
        got = tasks[task_id]
        assert (got["start"], got["finish"]) == (at(start_s), at(end_s))
        assert got["crews"] == [crew]
        component = task_id.split("-", 1)[1]
        assert got["products"] == [elements[component].GlobalId]
    assert sorted(tasks["R-B-H1"]["predecessors"]) == ["HI-S-11", "HI-S-12"]
    assert sorted(tasks["G-S-11"]["predecessors"]) == ["HI-S-11"]
    import ifcopenshell.validate

    exported = ifcopenshell.open(str(run / "floor-4d.ifc"))
    assert exported.schema == schema
    assert [s.Name for s in exported.by_type("IfcWorkSchedule")] == ["CMDP simulated schedule"]
    assert {t.Status for t in exported.by_type("IfcTask")} == {"FINISHED"}
    if schema == "IFC2X3":  # one IfcRelAssignsTasks a task, its times in TimeForTask
        rels = exported.by_type("IfcRelAssignsTasks")
        assert sorted(r.RelatedObjects[0].TaskId for r in rels) == sorted(sim)
        assert {r.RelatingControl.Name for r in rels} == {"CMDP simulated schedule"}
        hi = next(r.TimeForTask for r in rels if r.RelatedObjects[0].TaskId == "HI-S-11")
        start = hi.ScheduleStart
        assert (start.DateComponent.YearComponent, start.DateComponent.MonthComponent,
                start.DateComponent.DayComponent) == (2026, 3, 2)
        assert hi.ScheduleDuration == pytest.approx(float(sim["HI-S-11"][3])
                                                    - float(sim["HI-S-11"][2]))
    logger = ifcopenshell.validate.json_logger()  # the schema (EXPRESS rules: a slow test)
    ifcopenshell.validate.validate(exported, logger)
    assert logger.statements == []
    # the exported model imports again: its sequences now give the precedences
    data, report = import_storey(run / "floor-4d.ifc", "Level 1")
    assert report.precedences == "model"
    again = {t["id"]: sorted(t.get("predecessors", [])) for t in data["tasks"]}
    assert again == {t.id: sorted(t.predecessors) for t in case.tasks}


@pytest.mark.parametrize("schema, link", [("IFC4", "product"), ("IFC2X3", "product"),
                                          ("IFC4", "process"), ("IFC2X3", "process")])
def test_a_4d_sequence_replaces_the_recipes_links(tmp_path, schema, link):
    """The tasks build their elements whichever way they are linked: the task assigned to
    the element (IfcRelAssignsToProduct) or the element to the task (IfcRelAssignsToProcess)."""
    f, elements = ifc_models.two_by_two(schema)
    # "Install S-11" stands for S-11's whole chain; "HI S-12" for HI on S-12 only
    ifc_models.add_schedule(f, elements, {"Install S-11": ["S-11"], "HI S-12": ["S-12"],
                                          "Beam B-H1": ["B-H1"]},
                            [("Install S-11", "HI S-12"), ("HI S-12", "Beam B-H1")], link=link)
    path = tmp_path / "4d.ifc"
    f.write(str(path))
    data, report = import_storey(path, "Level 1")
    preds = {t["id"]: t.get("predecessors", []) for t in data["tasks"]}
    assert report.precedences == "model"
    assert preds["HI-S-12"] == ["JC-S-12", "G-S-11"]  # its chain, then the end of S-11's
    assert preds["R-B-H1"] == ["HI-S-12"]  # the model's link, not the recipe's two
    assert preds["R-B-V1"] == []  # no sequence reaches it: the recipe's links are gone
    assert preds["F-B-H1"] == ["R-B-H1"]


def test_bad_input_exits_2_with_one_message_and_writes_nothing(tmp_path, capsys):
    f, elements = ifc_models.two_by_two("IFC4")
    model = tmp_path / "floor.ifc"
    f.write(str(model))
    out = tmp_path / "case.toml"

    def fails(args, *expected):
        assert import_ifc.main(args + ["--out", str(out)]) == 2
        err = capsys.readouterr().err
        for text in expected:
            assert text in err, err
        assert not out.exists()

    text = tmp_path / "notes.ifc"
    text.write_text("hello")
    fails([str(text), "--storey", "Level 1"], "notes.ifc: is not an IFC file")
    fails([str(model), "--storey", "Level 9"], 'has no storey "Level 9"',
          'use one of its storeys: "Level 1", "Level 2"')
    fails([str(model), "--storey", "Level 2"], 'storey "Level 2" has no elements of the '
          "recipe's classes")
    overlay = tmp_path / "overlay.toml"
    overlay.write_text('[crews]\nJCC = 1\nHXC = 1\n[recipe.classes]\nIfcSlab = "precast"\n'
                       '[recipe.chains]\nprecast = [{type = "JC"}, {type = "HX"}]\n')
    fails([str(model), "--storey", "Level 1", "--overlay", str(overlay)],
          'overlay.toml: crews.HXC: names unknown crew type "HXC"; did you mean "HIC"?',
          'recipe.chains.precast[1]: type names unknown task type "HX"; fix: use one of "JC", '
          '"HI", "G", "R", "F"')
    overlay.write_text('[task_types.JC]\nname = "x"\ncrew_type = "JXC"\narea_distance_m = 1.0\n'
                       "congestion_index = 0.5\n")
    fails([str(model), "--storey", "Level 1", "--overlay", str(overlay)],
          'task type JC needs crew type "JXC", which is not in [crew_types]')
    overlay.write_text("[crews]\nJCC = 1\nHIC = 1\nRC = 1\nFC = 1\n")  # no GC
    fails([str(model), "--storey", "Level 1", "--overlay", str(overlay)],
          'overlay.toml: task type G (4 task(s) on the storey, e.g. G-S-11) needs a "GC" crew, '
          "and [crews] has none; fix: add GC = 1 to the overlay's [crews]")
    level = f.by_type("IfcBuildingStorey")[0]
    body = f.by_type("IfcGeometricRepresentationSubContext")[0]
    ifc_models.add_element(f, body, level, "IfcSlab", "S-X", ifc_models.box(101, 61, 2, 2))
    f.write(str(model))
    fails([str(model), "--storey", "Level 1"], 'IfcSlab "S-11"', 'IfcSlab "S-X"',
          "footprints overlap by 1.000 x 1.000 m")


def test_overlapping_and_poorly_boxed_footprints_are_reported(tmp_path, capsys):
    f, elements = ifc_models.two_by_two("IFC4")
    level = f.by_type("IfcBuildingStorey")[0]
    body = f.by_type("IfcGeometricRepresentationSubContext")[0]
    # a slab over S-11's top-right corner, and an L-shaped slab away from the floor
    ifc_models.add_element(f, body, level, "IfcSlab", "S-X", ifc_models.box(101, 61, 2, 2))
    ifc_models.add_element(f, body, level, "IfcSlab", "S-L",
                           [(90, 50), (94, 50), (94, 51), (91, 51), (91, 54), (90, 54)])
    path = tmp_path / "bad.ifc"
    f.write(str(path))
    # by default the L imports as drawn (a polygon): only the overlap is reported
    with pytest.raises(CaseError) as err:
        import_storey(path, "Level 1")
    assert 'IfcSlab "S-L"' not in str(err.value)
    assert "footprints overlap by 1.000 x 1.000 m" in str(err.value)
    boxes = tmp_path / "boxes.toml"  # boxed, as before polygons
    boxes.write_text("[import]\npolygons = false\n")
    with pytest.raises(CaseError) as err:
        import_storey(path, "Level 1", load_overlay(boxes))
    # L: 4 + 3 = 7 m2 of its 4 x 4 = 16 m2 rectangle -> 44%
    assert 'IfcSlab "S-L"' in str(err.value) and "fills 44% of its 4.00 x 4.00 m" in str(err.value)
    assert "min_fill = 0.43" in str(err.value)
    overlay = tmp_path / "o.toml"
    overlay.write_text("[import]\npolygons = false\nmin_fill = 0.4\n")
    with pytest.raises(CaseError) as err:
        import_storey(path, "Level 1", load_overlay(overlay))
    assert 'IfcSlab "S-11"' in str(err.value) and 'IfcSlab "S-X"' in str(err.value)
    assert "footprints overlap by 1.000 x 1.000 m" in str(err.value)


def test_elements_off_their_storey_are_reported_and_nothing_is_written(tmp_path, capsys):
    """Level 1 at z 0, Level 2 at 3.5 m (the model in millimetres): Level 1's elements start
    from -1.75 m (as far down as up: no storey below) up to 1.75 m (halfway to Level 2). A
    slab whose top is at the level (z -0.3..0) and a beam hanging 1.2 m under the floor sit on
    it (the beam, wholly below the level, carries the floor: a support, unless [import]
    supports leaves beams out); a slab of Level 2 (z 3.5..3.8) and a beam 20 m up, both
    assigned to Level 1, do not."""
    f, elements = ifc_models.two_by_two("IFC4")
    level = f.by_type("IfcBuildingStorey")[0]
    body = f.by_type("IfcGeometricRepresentationSubContext")[0]
    ifc_models.add_element(f, body, level, "IfcSlab", "S-TOP", ifc_models.box(120, 60, 2, 2),
                           z=-0.3)
    ifc_models.add_element(f, body, level, "IfcBeam", "B-DEEP", ifc_models.box(120, 50, 2, 1.2),
                           z=-1.2, depth=1.2)
    path = tmp_path / "storey.ifc"
    f.write(str(path))
    data, report = import_storey(path, "Level 1")
    assert "S-TOP" in {c["id"] for c in data["components"]}
    assert "B-DEEP" not in {c["id"] for c in data["components"]}
    assert report.supports_by_class == {"IfcBeam": 1}
    assert report.notes == []
    overlay = tmp_path / "o.toml"
    overlay.write_text('[import]\nsupports = ["IfcColumn"]\n')
    data, report = import_storey(path, "Level 1", load_overlay(overlay))
    assert {"S-TOP", "B-DEEP"} <= {c["id"] for c in data["components"]}
    assert report.supports_by_class == {}
    up = ifc_models.add_element(f, body, level, "IfcSlab", "S-UP", ifc_models.box(100, 60, 2, 2),
                                z=3.5)
    high = ifc_models.add_element(f, body, level, "IfcBeam", "B-HIGH",
                                  ifc_models.box(90, 55, 1.2, 2), z=20.0)
    f.write(str(path))
    out = tmp_path / "case.toml"
    assert import_ifc.main([str(path), "--storey", "Level 1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cmdp-import-ifc: storey.ifc: 2 problem(s)")
    level_1 = ('outside storey "Level 1" (level 0.00 m from the storey\'s placement: its '
               "elements start from -1.75 m up to 1.75 m)")
    set_level = ("; if the storey's level is wrong, set [import] level_m = ... (metres) in the "
                 "overlay, or give the storey an Elevation in the model")
    assert (f'IfcSlab "S-UP" ({up.GlobalId}): sits at z 3.50 m (the bottom of its body), '
            f'{level_1}, nearer storey "Level 2" (level 3.50 m) than its own; fix: assign it '
            'to "Level 2" in the model (IfcRelContainedInSpatialStructure) or correct its '
            "placement, or take the storey's elements as assigned with [import] check_storey "
            f"= false in the overlay{set_level}") in err
    assert (f'IfcBeam "B-HIGH" ({high.GlobalId}): sits at z 20.00 m (the bottom of its body), '
            f"{level_1}, on no storey of the building; fix: correct its placement in the "
            "model (its elevation, or its unit), or take the storey's elements as assigned "
            f"with [import] check_storey = false in the overlay{set_level}") in err
    assert "overlap" not in err  # S-UP lies over S-11 in plan: its storey is the cause
    assert not out.exists()
    # taken as assigned, S-UP is a footprint over S-11's
    overlay.write_text("[import]\ncheck_storey = false\n")
    with pytest.raises(CaseError, match='IfcSlab "S-11" .* and IfcSlab "S-UP" .*: footprints '
                                        "overlap by 2.000 x 2.000 m"):
        import_storey(path, "Level 1", load_overlay(overlay))
    overlay.write_text("[import]\ncheck_storey = 1\n")
    with pytest.raises(CaseError, match="import.check_storey = 1: write true or false"):
        load_overlay(overlay)


def test_the_storeys_ranges_by_hand():
    """Levels 0 and 3.5 m: Level 1 spans -1.75..1.75 m (as far down as up: none below),
    Level 2 1.75..5.25 m (none above: as far up as down); a roof at 10 m makes Level 2's
    1.75..6.75 m and its own 6.75..13.25 m; a storey alone spans its level +- 2 m (a nominal
    4 m storey)."""
    from cmdp_pymunk.cases.ifc_storey import storey_range

    def span(model, storey):
        r = storey_range(model, storey)
        return r.level_m, r.low_m, r.high_m

    f, _, storeys = ifc_models.new_model("IFC4")
    assert span(f, storeys["Level 1"]) == (0.0, -1.75, 1.75)
    assert span(f, storeys["Level 2"]) == (3.5, 1.75, 5.25)
    import ifcopenshell.api.aggregate
    import ifcopenshell.api.root

    building = f.by_type("IfcBuilding")[0]
    roof = ifcopenshell.api.root.create_entity(f, ifc_class="IfcBuildingStorey", name="Roof")
    ifcopenshell.api.aggregate.assign_object(f, products=[roof], relating_object=building)
    roof.Elevation = 10000.0  # no placement: the Elevation, in millimetres
    assert span(f, storeys["Level 2"]) == (3.5, 1.75, 6.75)
    assert span(f, roof) == (10.0, 6.75, 13.25)
    level_1 = storey_range(f, storeys["Level 1"])
    assert level_1.sits_on(9.0).name == "Roof" and level_1.sits_on(6.0).name == "Level 2"
    assert level_1.sits_on(0.5) is None and level_1.sits_on(20.0) is None
    alone, _, lone = ifc_models.new_model("IFC2X3")
    ifcopenshell.api.aggregate.unassign_object(alone, products=[lone["Level 2"]])
    alone.remove(lone["Level 2"])
    assert span(alone, lone["Level 1"]) == (0.0, -2.0, 2.0)


def test_a_storey_without_a_level_takes_its_slabs_tops_and_says_so(tmp_path):
    """two_by_two's storeys without placements (IFC2X3: no Elevation either): the level is
    the slabs' tops, 0.30 m (z 0..0.3), stated in the notes; the beams (z 0..0.5) rise above
    it and stay components. Without slabs in the recipe (beams only, as precast) the storey
    has no level at all: heights unchecked, no supports, a note that says how to set one."""
    f, _ = ifc_models.two_by_two("IFC2X3")
    for storey in f.by_type("IfcBuildingStorey"):
        storey.ObjectPlacement = None
    path = tmp_path / "nolevel.ifc"
    f.write(str(path))
    data, report = import_storey(path, "Level 1")
    assert report.notes == ['storey "Level 1": level 0.30 m from the slabs\' tops (the storey '
                            "has neither an Elevation nor a placement): supports lie below it "
                            "and its elements' heights are checked against it; if that is not "
                            "the storey's level, set [import] level_m = ... (metres) in the "
                            "overlay, or give the storey an Elevation in the model"]
    assert report.components_by_class == {"IfcSlab": 4, "IfcBeam": 4}
    assert report.supports_by_class == {}
    overlay = tmp_path / "beams.toml"
    overlay.write_text('[recipe.classes]\nIfcBeam = "precast"\n[recipe.chains]\n'
                       'precast = [{type = "JC"}, {type = "HI"}, {type = "G"}]\n')
    _, report = import_storey(path, "Level 1", load_overlay(overlay))
    assert report.notes[0] == (
        'storey "Level 1" has no level (neither an Elevation nor a placement, no slabs to take '
        "it from, no [import] level_m in the overlay): its elements' heights are not checked, "
        "and none is taken as a support under its floor ([import] supports); fix: set [import] "
        "level_m = ... (metres) in the overlay, or give the storey an Elevation in the model")


def test_a_fixed_plane_too_small_is_reported(two_by_two, tmp_path):
    overlay = tmp_path / "o.toml"
    overlay.write_text("[plane]\nwidth_m = 10.0\n")
    with pytest.raises(CaseError, match="outside the plane"):
        import_storey(two_by_two[0], "Level 1", load_overlay(overlay))


@pytest.mark.parametrize("schema", ["IFC4", "IFC2X3"])
def test_a_cycle_in_the_4d_sequence_is_reported(tmp_path, capsys, schema):
    f, elements = ifc_models.two_by_two(schema)
    ifc_models.add_schedule(f, elements, {"A": ["S-11"], "B": ["S-12"]}, [("A", "B"), ("B", "A")])
    path = tmp_path / "cycle.ifc"
    f.write(str(path))
    assert import_ifc.main([str(path), "--storey", "Level 1", "--out",
                            str(tmp_path / "c.toml")]) == 2
    err = capsys.readouterr().err
    assert "cycle of IfcRelSequence" in err and 'IfcTask "A"' in err and 'IfcTask "B"' in err
    assert not (tmp_path / "c.toml").exists()


def test_an_ifc2x3_model_without_a_user_cannot_take_a_4d_schedule(tmp_path, capsys):
    """IFC2X3's owner history is mandatory: a model that names no user and application
    (not one a BIM tool writes) is refused before simulating."""
    f, _ = ifc_models.two_by_two("IFC2X3")
    path = tmp_path / "floor.ifc"
    f.write(str(path))
    case_file = tmp_path / "c.toml"
    assert import_ifc.main([str(path), "--storey", "Level 1", "--out", str(case_file)]) == 0
    for pao in f.by_type("IfcPersonAndOrganization"):
        for history in f.by_type("IfcOwnerHistory"):
            history.OwningUser = history.LastModifyingUser = None
        f.remove(pao)
    f.write(str(path))
    assert simulate.main(["--case", str(case_file), "--out", str(tmp_path / "r"), "--ifc",
                          str(path), "--no-progress", "--no-charts"]) == 2
    err = capsys.readouterr().err
    assert "is IFC2X3, where every entity needs an owner history" in err
    assert "fix: save it again from a BIM tool" in err
    assert not (tmp_path / "r").exists()


def test_the_written_file_is_toml_with_the_guids(two_by_two, tmp_path):
    case_file = tmp_path / "c.toml"
    assert import_ifc.main([str(two_by_two[0]), "--storey", "Level 1", "--out",
                            str(case_file)]) == 0
    data = tomllib.loads(case_file.read_text())
    assert {c["id"]: c["ifc_guid"] for c in data["components"]} == two_by_two[1]


def test_the_sample_model_gives_the_built_in_case_back():
    """cases/precast_floor.ifc is the built-in floor as BIM (tools/make_sample_ifc.py): the
    importer's default overlay and recipe give back its components, tasks, crews, storages,
    plane and crane; only the name and the time limit (1,000 s per task) differ."""
    import cmdp_pymunk
    from cmdp_pymunk.cases.load import case_from_dict

    sample = cmdp_pymunk.BUILTIN_CASE.with_name("precast_floor.ifc")
    data, report = import_storey(sample, "Level 1")
    imported = case_from_dict(data).model_dump()
    builtin = load_case().model_dump()
    assert all(c.pop("ifc_guid") for c in imported["components"])
    assert not any(c.pop("ifc_guid") for c in builtin["components"])
    for case in (imported, builtin):
        case.pop("case")
        case["simulation"].pop("max_time_s")
    assert imported == builtin
    assert report.components_by_class == {"IfcSlab": 15, "IfcBeam": 21}


def test_the_sample_model_is_what_its_tool_writes():
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    sample = root / "cmdp_pymunk" / "cases" / "precast_floor.ifc"
    code = ("import sys; sys.path.insert(0, 'tools'); import make_sample_ifc as m; "
            "import cmdp_pymunk; "
            "print(m.model_from_case(cmdp_pymunk.load_case(), storey='Level 1', "
            "origin=m.ORIGIN_M, seed='precast-floor').to_string(), end='')")
    # a fresh process: a second model built in one process numbers its entities differently
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True,
                         text=True, check=True).stdout
    assert out == sample.read_text(), "run python tools/make_sample_ifc.py"
    assert len(out) < 300_000


def test_the_docs_overlay_example_loads_and_imports_the_sample(tmp_path):
    """docs/ifc.md's overlay (every section, at the defaults but for the storages' places
    and the columns it maps to an obstacle kind, of which the sample has none) gives the
    same components and tasks as no overlay."""
    import re
    from pathlib import Path

    import cmdp_pymunk

    page = (Path(__file__).resolve().parent.parent / "docs" / "ifc.md").read_text()
    block = re.search(r"```toml\n(.*?)```", page, re.S).group(1)
    overlay = tmp_path / "overlay.toml"
    overlay.write_text(block)
    sample = cmdp_pymunk.BUILTIN_CASE.with_name("precast_floor.ifc")
    with_overlay, _ = import_storey(sample, "Level 1", load_overlay(overlay))
    default, _ = import_storey(sample, "Level 1")
    assert with_overlay["tasks"] == default["tasks"]
    assert with_overlay["components"] == default["components"]
    # x_frac -0.44 of the half width 27 m: -11.88 m instead of the default -12
    assert [s["x_m"] for s in with_overlay["storages"]] == [-11.88, 11.88, 0.0]


def test_overlay_typos_and_bad_storages_are_named(tmp_path):
    overlay = tmp_path / "o.toml"
    overlay.write_text('[plane]\nmargin_x = 5.0\n[import]\nmin_fill = "high"\n'
                       '[[storages]]\nid = "S"\nmaterial = "rebars"\nwidth = 2.0\n'
                       'edge = "left"\n[recipe]\nneighbour_gap_m = 3.0\n'
                       '[recipe.chains]\nprecast = [{type = "JC"}]\n[wheels]\n')
    with pytest.raises(CaseError) as err:
        load_overlay(overlay)
    text = str(err.value)
    for expected in ('plane.margin_x: unknown field; did you mean "margin_x_m"?',
                     "import.min_fill = 'high': write a number",
                     "storages[0]: width_m missing", 'storages[0]: width: unknown field',
                     'storages[0]: edge = \'left\'; fix: write "top" or "bottom"',
                     "recipe.neighbour_gap_m: unknown field", "[wheels]: unknown section"):
        assert expected in text, text
    assert text.startswith("o.toml: ")


def test_a_lane_narrower_than_a_crew_is_noted(tmp_path):
    """A slab 1 m right of S-22 (x 112..114): the lane between them is 1 m, narrower than the
    HIC (5 m2: 2 sqrt(5 / pi) = 2.52 m across)."""
    f, elements = ifc_models.two_by_two("IFC4")
    level = f.by_type("IfcBuildingStorey")[0]
    body = f.by_type("IfcGeometricRepresentationSubContext")[0]
    ifc_models.add_element(f, body, level, "IfcSlab", "S-23", ifc_models.box(113, 50, 2, 2))
    path = tmp_path / "lane.ifc"
    f.write(str(path))
    _, report = import_storey(path, "Level 1")
    assert report.notes == ['the lane between IfcSlab "S-22" ({}) and IfcSlab "S-23" ({}) is '
                            "1.00 m wide, narrower than the widest crew (2.52 m): no crew "
                            "passes there".format(elements["S-22"].GlobalId,
                                                  f.by_type("IfcSlab")[-1].GlobalId)]


def test_a_start_start_sequence_is_noted_and_read_as_finish_start(tmp_path):
    f, elements = ifc_models.two_by_two("IFC4")
    ifc_models.add_schedule(f, elements, {"A": ["S-11"], "B": ["S-12"]}, [("A", "B")],
                            kind="START_START")
    path = tmp_path / "ss.ifc"
    f.write(str(path))
    data, report = import_storey(path, "Level 1")
    assert len(report.notes) == 1 and 'IfcTask "A"' in report.notes[0]
    assert report.notes[0].endswith("is START_START; read as FINISH_START")
    assert {t["id"]: t.get("predecessors") for t in data["tasks"]}["JC-S-12"] == ["G-S-11"]


@pytest.mark.slow
@pytest.mark.parametrize("schema", ["IFC4", "IFC2X3"])
def test_the_4d_export_passes_the_express_rules(tmp_path, schema):
    """The export of a hand-made schedule (no simulation) against the schema's EXPRESS rules
    too (about 5 s: the rules are loaded); IFC2X3's say one task to an IfcRelAssignsTasks."""
    import datetime

    import ifcopenshell.validate

    from cmdp_pymunk.cases.ifc_export import export_4d
    from cmdp_pymunk.cases.load import case_from_dict
    from cmdp_pymunk.schedule import TaskBar

    f, _ = ifc_models.two_by_two(schema)
    model = tmp_path / "floor.ifc"
    f.write(str(model))
    case = case_from_dict(import_storey(model, "Level 1")[0])
    bars = [TaskBar("JC-S-11", "JCC-1", ((0.0, 700.0),), True),
            TaskBar("HI-S-11", "HIC-1", ((700.0, 900.0), (1000.0, 1500.0)), False)]
    counts = export_4d(model, case, bars, tmp_path / "4d.ifc", datetime.datetime(2026, 1, 5, 8))
    assert counts == {"tasks": 20, "timed": 2, "sequences": 20, "crews": 7}
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(ifcopenshell.open(str(tmp_path / "4d.ifc")), logger,
                                   express_rules=True)
    assert logger.statements == []
    tasks = {t["id"]: t for t in read_4d(tmp_path / "4d.ifc")}
    assert (tasks["HI-S-11"]["start"], tasks["HI-S-11"]["finish"]) == ("2026-01-05T08:11:40",
                                                                      "2026-01-05T08:25:00")
    assert tasks["G-S-11"]["start"] is None  # not started: no times


def test_duplicate_names_get_class_numbered_ids_and_missing_geometry_is_reported(tmp_path):
    import ifcopenshell.api.root
    import ifcopenshell.api.spatial

    f, body, storeys = ifc_models.new_model("IFC4")
    level = storeys["Level 1"]
    for x in (0.0, 10.0):
        ifc_models.add_element(f, body, level, "IfcSlab", "Slab", ifc_models.box(x, 0, 2, 2))
    ifc_models.add_element(f, body, level, "IfcBeam", "", ifc_models.box(5, 0, 2, 1.2))
    path = tmp_path / "dup.ifc"
    f.write(str(path))
    data, _ = import_storey(path, "Level 1")
    assert [c["id"] for c in data["components"]] == ["Slab-1", "Slab-2", "Beam-1"]
    assert {t["id"]: t.get("predecessors") for t in data["tasks"]}["R-Beam-1"] == [
        "HI-Slab-1", "HI-Slab-2"]
    column = ifcopenshell.api.root.create_entity(f, ifc_class="IfcColumn", name="C-1")
    ifcopenshell.api.spatial.assign_container(f, products=[column], relating_structure=level)
    f.write(str(path))
    with pytest.raises(CaseError, match='IfcColumn "C-1" .*: has no body geometry'):
        import_storey(path, "Level 1")


def test_crews_come_only_for_crew_types_with_work(two_by_two, tmp_path):
    """A slabs-only recipe on the 2 x 2 floor: JC, HI and G tasks need JCC, HIC and GC; the
    default overlay's two RC and two FC crews would idle all floor: they are left out, said."""
    overlay = tmp_path / "slabs.toml"
    overlay.write_text('[recipe.classes]\nIfcSlab = "precast"\n'
                       '[recipe.chains]\nprecast = [{type = "JC"}, {type = "HI"}, '
                       '{type = "G"}]\n')
    data, report = import_storey(two_by_two[0], "Level 1", load_overlay(overlay))
    assert sorted(c["id"] for c in data["crews"]) == ["GC-1", "HIC-1", "JCC-1"]
    assert report.crews_left_out == {"RC": 2, "FC": 2}
    assert any("no work for crew type(s) RC (2 crews), FC (2 crews)" in n for n in report.notes)
    # the recipe with beams keeps every crew
    data, report = import_storey(two_by_two[0], "Level 1")
    assert len(data["crews"]) == 7 and report.crews_left_out == {}


def test_the_import_says_where_each_setting_came_from(two_by_two, tmp_path, capsys):
    overlay = tmp_path / "site.toml"
    overlay.write_text("[crews]\nJCC = 1\nHIC = 1\nGC = 1\nRC = 1\nFC = 1\n"
                       "[crane]\nlift_time_s = 300.0\n")
    _, report = import_storey(two_by_two[0], "Level 1", load_overlay(overlay))
    assert report.provenance["crews"] == report.provenance["crane"] == "overlay site.toml"
    assert report.provenance["storages"] == report.provenance["task_types"] == "default"
    assert import_ifc.settings_line(report.provenance).startswith(
        "from the overlay site.toml: crane, crews; defaults (docs/ifc.md): case, crew_types, ")
    out = tmp_path / "case.toml"
    assert import_ifc.main([str(two_by_two[0]), "--storey", "Level 1", "--out", str(out),
                            "--overlay", str(overlay)]) == 0
    printed = capsys.readouterr().out
    assert "settings: from the overlay site.toml: crane, crews; defaults" in printed
    import hashlib

    import cmdp_pymunk

    comments = " ".join(line[2:] for line in out.read_text().split("\n")
                        if line.startswith("# "))
    digest = hashlib.sha256(two_by_two[0].read_bytes()).hexdigest()[:16]
    assert comments.startswith(f"Imported from floor.ifc (SHA-256 {digest}...), storey "
                               f"'Level 1', by cmdp-import-ifc {cmdp_pymunk.__version__} with "
                               "the overlay site.toml.")
    assert "Settings: from the overlay site.toml: crane, crews; defaults" in comments
    load_case(out)  # the comments keep it a case file


@pytest.mark.parametrize("schema", ["IFC4", "IFC2X3"])
def test_the_4d_export_dates_tasks_through_the_case_s_calendar(tmp_path, schema):
    """Second 0 is Fri 2026-01-09 15:50 (600 s of Friday left), days 08:00-16:00 Mon-Fri, Mon
    12th a holiday: by hand, JC-S-11 (0-700 s) runs Fri 15:50 to Tue 13th 08:01:40 and
    HI-S-11 (700-1500 s) Tue 08:01:40 to 08:15:00; IFC4's durations are working time."""
    from cmdp_pymunk.cases.ifc_export import export_4d
    from cmdp_pymunk.cases.load import case_from_dict
    from cmdp_pymunk.cases.model import Calendar
    from cmdp_pymunk.schedule import TaskBar

    f, _ = ifc_models.two_by_two(schema)
    model = tmp_path / "floor.ifc"
    f.write(str(model))
    case = case_from_dict(import_storey(model, "Level 1")[0]).model_copy(update={
        "calendar": Calendar(start="2026-01-09T15:50", holidays=["2026-01-12"])})
    bars = [TaskBar("JC-S-11", "JCC-1", ((0.0, 700.0),), True),
            TaskBar("HI-S-11", "HIC-1", ((700.0, 900.0), (1000.0, 1500.0)), True)]
    export_4d(model, case, bars, tmp_path / "4d.ifc", None)
    tasks = {t["id"]: t for t in read_4d(tmp_path / "4d.ifc")}
    assert (tasks["JC-S-11"]["start"], tasks["JC-S-11"]["finish"]) == ("2026-01-09T15:50:00",
                                                                      "2026-01-13T08:01:40")
    assert (tasks["HI-S-11"]["start"], tasks["HI-S-11"]["finish"]) == ("2026-01-13T08:01:40",
                                                                      "2026-01-13T08:15:00")
    if schema == "IFC4":
        exported = ifcopenshell.open(str(tmp_path / "4d.ifc"))
        times = {t.Identification: t.TaskTime for t in exported.by_type("IfcTask")}
        assert times["JC-S-11"].DurationType == "WORKTIME"
        assert times["JC-S-11"].ScheduleDuration == "PT11M40S"  # 700 working seconds


def test_simulate_with_a_calendar_exports_the_dates_of_schedule_csv(tmp_path):
    """``cmdp-simulate --ifc --start``: each task's 4D start and finish are its schedule.csv
    dates (one mapping, ``workcalendar``, for both)."""
    f, _ = ifc_models.two_by_two("IFC4")
    model = tmp_path / "floor.ifc"
    f.write(str(model))
    case_file = tmp_path / "floor.toml"
    assert import_ifc.main([str(model), "--storey", "Level 1", "--out", str(case_file)]) == 0
    run = tmp_path / "run"
    assert simulate.main(["--case", str(case_file), "--out", str(run), "--no-charts",
                          "--no-progress", "--ifc", str(model), "--start", "2026-01-09T14:00",
                          "--holidays", "2026-01-12"]) == 0
    import csv

    rows = list(csv.DictReader((run / "schedule.csv").open()))
    tasks = {t["id"]: t for t in read_4d(run / "floor-4d.ifc")}
    assert {r["task"]: (r["start"], r["end"]) for r in rows} == \
        {k: (t["start"], t["finish"]) for k, t in tasks.items()}
    assert max(r["end"] for r in rows) > "2026-01-13"  # past the weekend and the holiday


@pytest.mark.parametrize("schema", ["IFC4", "IFC2X3"])
def test_slabs_without_a_shape_take_their_footprints_from_aggregated_proxies(tmp_path, schema):
    """The precast deck (``ifc_models.precast_deck``): 9 IfcSlab with a placement and no shape,
    each body on an IfcBuildingElementProxy aggregated to it, in a 'Plan' context, in
    millimetres, bottoms 0.25 m below the level. The model spans x 200..209.16 (three 3 m slabs
    and two joints of 80 mm in row 3), y 100..111.6 (three 1.2 m rows, 4 m apart): its centre
    (204.58, 105.8) is the origin. Row 1 (joints 0): x centres 201.5, 204.5, 207.5 -> -3.08,
    -0.08, 2.92; row 2 (20 mm): 201.5, 204.52, 207.54 -> -3.08, -0.06, 2.96; row 3 (80 mm):
    201.5, 204.58, 207.66 -> -3.08, 0, 3.08; rows' y centres 100.6, 105.8, 111 -> -5.2, 0,
    5.2."""
    import ifcopenshell.util.unit

    f, slabs = ifc_models.precast_deck(schema)
    path = tmp_path / "deck.ifc"
    f.write(str(path))
    model = ifcopenshell.open(str(path))
    assert ifcopenshell.util.unit.calculate_unit_scale(model) == 0.001  # millimetres
    assert {s.Depth for s in model.by_type("IfcExtrudedAreaSolid")} == {250.0}
    assert all(s.Representation is None for s in model.by_type("IfcSlab"))
    assert {r.ContextOfItems.ContextType for r in model.by_type("IfcShapeRepresentation")} \
        == {"Plan"}
    data, report = import_storey(path, "Level 1")
    comps = {c["id"]: (c["x_m"], c["y_m"], c["width_m"], c["height_m"])
             for c in data["components"]}
    assert comps == {
        "D-11": (-3.08, -5.2, 3.0, 1.2), "D-12": (-0.08, -5.2, 3.0, 1.2),
        "D-13": (2.92, -5.2, 3.0, 1.2),
        "D-21": (-3.08, 0.0, 3.0, 1.2), "D-22": (-0.06, 0.0, 3.0, 1.2),
        "D-23": (2.96, 0.0, 3.0, 1.2),
        "D-31": (-3.08, 5.2, 3.0, 1.2), "D-32": (0.0, 5.2, 3.0, 1.2),
        "D-33": (3.08, 5.2, 3.0, 1.2)}
    assert {c["id"]: c["ifc_guid"] for c in data["components"]} == {
        n: s.GlobalId for n, s in slabs.items()}
    # the proxies are parts, neither components nor skipped
    assert report.components_by_class == {"IfcSlab": 9} and report.skipped_by_class == {}
    assert ("9 IfcSlab without a body of their own: footprints from the elements aggregated "
            "to them (IfcBuildingElementProxy), which are not components") in report.notes
    # slabs side by side with joints of 0, 20 and 80 mm (at most [import] deck_joint_max_m,
    # 0.1 m) are decks, walked on once laid: their joints are no lanes to note
    assert all(c["deck"] for c in data["components"])
    assert ("9 IfcSlab side by side with joints of at most 0.1 m ([import] deck_joint_max_m) "
            "form decks: obstacles until installed, walked on after") in report.notes
    assert not [n for n in report.notes if n.startswith("the lane between")]
    # with joints of at most 10 mm only row 1's slabs are a deck; the 20 and 80 mm joints are
    # lanes no crew passes (noted), the 0 mm ones are none
    overlay = tmp_path / "o.toml"
    overlay.write_text("[import]\ndeck_joint_max_m = 0.01\n")
    data, report = import_storey(path, "Level 1", load_overlay(overlay))
    assert {c["id"] for c in data["components"] if c.get("deck")} == {"D-11", "D-12", "D-13"}
    lanes = [n for n in report.notes if n.startswith("the lane between")]
    assert len(lanes) == 4 and sum(" 0.02 m wide" in n for n in lanes) == 2
    # a slab with neither a body nor parts is still refused
    import ifcopenshell.api.root
    import ifcopenshell.api.spatial

    bare = ifcopenshell.api.root.create_entity(f, ifc_class="IfcSlab", name="D-BARE")
    ifcopenshell.api.spatial.assign_container(f, products=[bare],
                                              relating_structure=slabs["D-11"]
                                              .ContainedInStructure[0].RelatingStructure)
    f.write(str(path))
    with pytest.raises(CaseError, match=r'IfcSlab "D-BARE" .*: has no body geometry to take a '
                                        r"footprint from, neither its own nor its parts'"):
        import_storey(path, "Level 1")


@pytest.mark.parametrize("schema", ["IFC4", "IFC2X3"])
def test_beams_columns_and_walls_under_the_slabs_are_supports(tmp_path, capsys, schema):
    """``ifc_models.slabs_on_beams``: four 6 x 3 m slabs on the level (z 0..0.3) bear on four
    crossing beams (z -0.6..0), six columns at their corners (z -3.5..0) and a wall of the
    storey below (z -3..0); a wall stands on the floor (z 0..3) at x 15..15.3. Below the level
    (tops at 0): 4 IfcBeam, 6 IfcColumn, 1 IfcWall are supports; the slabs and the standing
    wall are the components. Their box x 0..15.3, y 0..6 centres on (7.65, 3): S-1 (3, 1.5)
    -> (-4.65, -1.5), S-4 (9, 4.5) -> (1.35, 1.5), W-1 (15.15, 3) -> (7.5, 0)."""
    f, made = ifc_models.slabs_on_beams(schema)
    path = tmp_path / "structure.ifc"
    f.write(str(path))
    data, report = import_storey(path, "Level 1")
    comps = {c["id"]: (c["x_m"], c["y_m"], c["width_m"], c["height_m"])
             for c in data["components"]}
    assert comps == {"S-1": (-4.65, -1.5, 6.0, 3.0), "S-2": (1.35, -1.5, 6.0, 3.0),
                     "S-3": (-4.65, 1.5, 6.0, 3.0), "S-4": (1.35, 1.5, 6.0, 3.0),
                     "W-1": (7.5, 0.0, 0.3, 6.0)}
    assert report.components_by_class == {"IfcSlab": 4, "IfcWall": 1}
    assert report.supports_by_class == {"IfcBeam": 4, "IfcColumn": 6, "IfcWall": 1}
    assert report.tasks == 15  # 5 precast components x (JC, HI, G)
    out = tmp_path / "case.toml"
    assert import_ifc.main([str(path), "--storey", "Level 1", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert ("5 components (4 IfcSlab, 1 IfcWall)" in printed
            and "supports (below the storey's level, carrying it; not obstacles): 4 IfcBeam, "
            "6 IfcColumn, 1 IfcWall" in printed)
    # every element an obstacle (and the columns' bottoms, 3.5 m down, not checked): 37
    # overlaps by hand. Each slab meets the 3 beams under its edges (2 along y, B-X) and its
    # 2 columns, S-1 and S-2 the wall below too: 6 + 6 + 5 + 5 = 22; B-X crosses B-1, B-2,
    # B-3: 3; each of B-1..B-3 meets its 2 columns and the wall: 9; C-1..C-3 the wall: 3
    overlay = tmp_path / "o.toml"
    overlay.write_text("[import]\nsupports = []\ncheck_storey = false\n")
    with pytest.raises(CaseError) as err:
        import_storey(path, "Level 1", load_overlay(overlay))
    assert len(err.value.problems) == 37
    assert (f'IfcBeam "B-2" ({made["B-2"].GlobalId}) and IfcBeam "B-X" ({made["B-X"].GlobalId})'
            ": footprints overlap by 0.400 x 0.400 m") in str(err.value)
    assert "list its class in [import] supports" in str(err.value)
    for bad in ('"IfcBeam"', '["Beam"]'):
        overlay.write_text(f"[import]\nsupports = {bad}\n")
        with pytest.raises(CaseError, match=r"import.supports = .*: write a list of IFC "
                                            r"classes whose elements below the storey's level"):
            load_overlay(overlay)


# -- decks: slabs walked on once laid (issue 31, item 1) ---------------------------------------

@pytest.fixture(scope="module")
def wide_deck(tmp_path_factory):
    f, slabs = ifc_models.wide_slab_deck("IFC4")
    path = tmp_path_factory.mktemp("wide") / "wide.ifc"
    f.write(str(path))
    return path, {n: s.GlobalId for n, s in slabs.items()}


def _run_to_the_end(data: dict, seed: int = 0):
    """The case of ``data`` on the pymunk floor with the scripted navigator, to its end."""
    from agents.navigator import Navigator
    from cmdp_pymunk.cases.load import case_from_dict
    from cmdp_pymunk.engine import Engine
    from cmdp_pymunk.rollout import run_episode

    engine = Engine(case_from_dict(data, "deck"), evaluator="priority")
    episode = run_episode(engine, Navigator(), seed, stall_s=None, progress=False)
    assert episode.makespan_s is not None and engine.site.done
    return engine


def test_a_wide_slab_deck_is_walked_on_once_laid(wide_deck):
    """``ifc_models.wide_slab_deck``: 5 x 5 slabs 4 x 2.4 m with joints of 0-80 mm, no lane
    through them. As obstacles side by side the inner nine could never be reached; as a deck
    they are, over the slabs laid around them. Slab W-33's work points lie 2 rows (2 x 2.4 m
    plus joints) in from every edge: JC's band (area 1.2 + 0.6 m) and HI's (2.5 + 0.6 m) fall
    short of the open floor, so its tasks wait until slabs between it and the edge are laid."""
    from cmdp_pymunk.cases.load import case_from_dict
    from cmdp_pymunk.cases.reach import Reach, laying_tasks

    path, guids = wide_deck
    data, report = import_storey(path, "Level 1")
    assert {c["id"]: c["ifc_guid"] for c in data["components"]} == guids
    assert all(c["deck"] for c in data["components"]) and len(data["tasks"]) == 75
    assert not [n for n in report.notes if n.startswith("the lane between")]
    case = case_from_dict(data, "wide.toml")  # the reachability check passes
    assert laying_tasks(case)["HI-W-33"] == "W-33"  # a slab is laid when installed (HI)
    reach = Reach.of(case)
    tasks = {t.id: k for k, t in enumerate(case.tasks)}
    hic = next(c for c in case.crews if c.type == "HIC")
    radius = case.crew_types["HIC"].radius_m
    start = (hic.start_x_m, hic.start_y_m)
    assert reach.reaches(radius, start, tasks["HI-W-13"])  # on the edge
    assert not reach.reaches(radius, start, tasks["HI-W-33"])  # in the middle, nothing laid
    comps = {c.id: k for k, c in enumerate(case.components)}
    laid = frozenset(comps[f"W-{k}"] for k in (11, 12, 13, 14, 15, 21, 22, 23, 24, 25))
    assert reach.reaches(radius, start, tasks["HI-W-33"], laid)  # rows 1 and 2 laid
    engine = _run_to_the_end(data)
    site = engine.site
    assert site.laid == frozenset(range(25))
    ends = {t.id: t.ended_s for t in site.tasks}
    starts = {t.id: t.started_s for t in site.tasks}
    # nothing inside is started before a slab beside it (on the way in) is laid
    for r, c in ((2, 2), (2, 3), (3, 3), (4, 4)):
        beside = [f"HI-W-{r + dr}{c + dc}" for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1))]
        assert starts[f"JC-W-{r}{c}"] >= min(ends[t] for t in beside)


@pytest.mark.parametrize("schema", ["IFC4", "IFC2X3"])
def test_an_l_shaped_storey_of_hollow_core_slabs_imports_and_simulates(tmp_path, schema):
    """``ifc_models.l_storey``: twelve hollow-core slabs in an L (20 mm joints: one deck) on
    three beams and six columns below the level (supports). The L's box x 0..9.74, y 0..12.02
    centres on (4.87, 6.01): H-1 (0.6, 3) -> (-4.27, -3.01), H-12 (4.26, 9.02) -> (-0.61,
    3.01)."""
    f, made = ifc_models.l_storey(schema)
    path = tmp_path / "l.ifc"
    f.write(str(path))
    data, report = import_storey(path, "Level 1")
    comps = {c["id"]: (c["x_m"], c["y_m"], c["width_m"], c["height_m"], c["deck"])
             for c in data["components"]}
    assert len(comps) == 12 and all(c[4] for c in comps.values())
    assert comps["H-1"] == (-4.27, -3.01, 1.2, 6.0, True)
    assert comps["H-12"] == (-0.61, 3.01, 1.2, 6.0, True)
    assert report.supports_by_class == {"IfcBeam": 3, "IfcColumn": 6}
    assert not [n for n in report.notes if n.startswith("the lane between")]
    if schema == "IFC4":
        _run_to_the_end(data)


def test_the_precast_deck_imports_and_simulates(tmp_path):
    """``ifc_models.precast_deck``'s nine slabs (three rows of three, 0-80 mm joints) are
    decks: it imports, passes the check and runs to the end."""
    f, _ = ifc_models.precast_deck("IFC4")
    f.write(str(tmp_path / "deck.ifc"))
    data, _ = import_storey(tmp_path / "deck.ifc", "Level 1")
    assert _run_to_the_end(data).site.laid == frozenset(range(9))


def test_a_deck_slab_no_crew_can_reach_is_refused(wide_deck):
    """The wide-slab deck with W-33's eight neighbours made no decks (obstacles for good):
    W-33 is walled in, and its tasks are named with the fix; the 16 decks around them are
    laid (W-33, a deck too, never is)."""
    from cmdp_pymunk.cases.load import case_from_dict

    data, _ = import_storey(wide_deck[0], "Level 1")
    walls = {f"W-{r}{c}" for r in (2, 3, 4) for c in (2, 3, 4)} - {"W-33"}
    for c in data["components"]:
        if c["id"] in walls:
            c["deck"] = False
    with pytest.raises(CaseError) as err:
        case_from_dict(data, "wide.toml")
    text = str(err.value)
    assert ("tasks: JC-W-33 (JC on W-33): no JCC crew can reach its work point from where the "
            "JCC crews start, over open floor and the decks laid before it (16 of 17 decks can "
            "be laid)") in text
    assert "fix: add an access lane to W-33 or widen a joint next to it" in text
    assert "W-22" not in text  # its neighbours are reached over the decks laid around them


MODELS = {  # the storeys issue 31 names: (model, schema, overlay TOML or None)
    "slabs-on-beams": ("slabs_on_beams", "IFC4"),
    "two-storeys-ifc2x3": ("two_by_two", "IFC2X3"),
    "wide-slab-deck": ("wide_slab_deck", "IFC4"),
    "l-storey": ("l_storey", "IFC2X3"),
    "precast-deck": ("precast_deck", "IFC4"),
}


STOREY_SEEDS_SAMPLE = 5  # seeds 0-4 in the slow set (CI): about a quarter of the sweep's time
STOREY_SEEDS_ALL = 20  # seeds 0-19 in the nightly set (before a release)


@pytest.mark.slow
@pytest.mark.parametrize("episodes", [
    pytest.param(STOREY_SEEDS_SAMPLE, id="sample"),
    pytest.param(STOREY_SEEDS_ALL, marks=pytest.mark.nightly, id="all")])
@pytest.mark.parametrize("name", [*MODELS, "tasks-and-sequences"])
def test_each_storey_imports_simulates_its_seeds_and_exports_valid_4d(tmp_path, name, episodes):
    """Each model the tests write with ``ifcopenshell.api`` imports with the default recipe,
    passes the reachability check, runs to the end on seeds 0-4 (the slow set; 0-19 in the
    nightly set: a floor of wide-slab-deck costs about 5 s), and its 4D export passes
    ``ifcopenshell.validate`` (seed 0's)."""
    import json

    import ifcopenshell.validate

    if name == "tasks-and-sequences":
        f, elements = ifc_models.two_by_two("IFC4")
        ifc_models.add_schedule(f, elements, {"slabs": ["S-11", "S-12"], "beam": ["B-H1"]},
                                [("slabs", "beam")])
    else:
        model, schema = MODELS[name]
        f, _ = getattr(ifc_models, model)(schema)
    path = tmp_path / "m.ifc"
    f.write(str(path))
    case_file = tmp_path / "case.toml"
    assert import_ifc.main([str(path), "--storey", "Level 1", "--out", str(case_file)]) == 0
    run = tmp_path / "run"
    assert simulate.main(["--case", str(case_file), "--out", str(run), "--episodes",
                          str(episodes), "--no-charts", "--no-progress", "--ifc", str(path)]) == 0
    for seed in range(episodes):
        summary = json.loads((run / f"seed-{seed}" / "summary.json").read_text())
        assert summary["tasks_finished"] == summary["tasks_total"], (name, seed)
    def problems(model: Path) -> list[str]:
        logger = ifcopenshell.validate.json_logger()
        ifcopenshell.validate.validate(ifcopenshell.open(str(model)), logger,
                                       express_rules=True)
        # the rule and the instance breaking it (the message also holds object addresses)
        return sorted(f'{s["message"].splitlines()[0]} on {s["instance"]}'
                      for s in logger.statements)

    # the export adds nothing invalid: precast_deck's own bodies, in a 'Plan' context without
    # a RepresentationIdentifier, break an EXPRESS rule in the model and in its copy alike
    assert problems(run / "seed-0" / "m-4d.ifc") == problems(path)
    if name != "precast-deck":
        assert problems(path) == []
