"""A storey's working level in the IFC import (``cmdp_pymunk.cases.ifc_levels``, issue 41
item 1): its routes (the overlay's ``[import] level_m``, the storey's Elevation, its
placement, its slabs' tops), and the notes and refusals that name the level and its route.
Models from ``tests/ifc_models.py`` (``raised_storey``: slabs z 3..3.3 on crossing beams and
columns). The pure functions run without IfcOpenShell; the rest is skipped without the
[ifc] extra."""

from __future__ import annotations

import importlib.util

import pytest

from cmdp_pymunk.cases.ifc_levels import describe, how_to_set, slabs_top_m, working_level
from cmdp_pymunk.cases.load import CaseError

needs_ifc = pytest.mark.skipif(importlib.util.find_spec("ifcopenshell") is None,
                               reason="needs the [ifc] extra (IfcOpenShell)")

ELEVATION_FIX = ("correct the storey's Elevation in the model, or set [import] level_m = ... "
                 "(metres) in the overlay")
MODEL_FIX = ("set [import] level_m = ... (metres) in the overlay, or give the storey an "
             "Elevation in the model")


# -- the routes, by hand -------------------------------------------------------------------

def test_the_first_route_that_gives_a_level_wins():
    # (overlay, Elevation, placement, slabs' tops)
    assert working_level(3.1, 3.0, 0.0, 3.3) == (3.1, "overlay")  # the user's word first
    assert working_level(None, 3.0, 0.0, 3.3) == (3.0, "elevation")  # over the placement
    assert working_level(None, None, 0.0, 3.3) == (0.0, "placement")  # a level at 0 counts
    assert working_level(None, None, None, 3.3) == (3.3, "slabs")
    assert working_level(-3.0, None, None, None) == (-3.0, "overlay")  # a basement
    assert working_level(None, None, None, None) == (None, "none")


def test_the_slabs_top_is_where_most_slab_area_reaches():
    # two 6 x 3 m slabs (18 m2 each) with tops at 3.30 m and a 30 m2 recessed bay at 3.25:
    # 36 m2 against 30 -> 3.30; a third 18 m2 slab at 3.25 makes it 48 against 36 -> 3.25
    assert slabs_top_m([(3.3, 18.0), (3.3, 18.0), (3.25, 30.0)]) == 3.3
    assert slabs_top_m([(3.3, 18.0), (3.3, 18.0), (3.25, 30.0), (3.25, 18.0)]) == 3.25
    # tops within half a millimetre are one top; a tie takes the higher
    assert slabs_top_m([(3.2999, 10.0), (3.3001, 10.0), (3.0, 20.0)]) == 3.3
    assert slabs_top_m([(3.0, 20.0), (3.3, 20.0)]) == 3.3
    assert slabs_top_m([]) is None


def test_a_level_is_described_with_its_route_and_how_to_set_it():
    assert describe(3.0, "placement") == "level 3.00 m from the storey's placement"
    assert describe(-1.5, "overlay") == "level -1.50 m from the overlay's [import] level_m"
    assert describe(3.3, "slabs") == ("level 3.30 m from the slabs' tops (the storey has "
                                      "neither an Elevation nor a placement)")
    assert describe(None, "none").startswith("no level (neither an Elevation nor a placement")
    assert how_to_set("elevation") == ELEVATION_FIX
    assert how_to_set("placement") == how_to_set("slabs") == how_to_set("none") == MODEL_FIX
    assert how_to_set("overlay") == "change [import] level_m in the overlay"


def test_the_overlay_level_is_validated(tmp_path):
    from cmdp_pymunk.cases.ifc_overlay import load_overlay

    overlay = tmp_path / "o.toml"
    overlay.write_text("[import]\nlevel_m = -3.0\n")  # below the model's origin: a basement
    assert load_overlay(overlay).data["import"]["level_m"] == -3.0
    assert "level_m" not in load_overlay(None).data["import"]  # the model's, by default
    for bad in ('"3 m"', "true", "nan"):
        overlay.write_text(f"[import]\nlevel_m = {bad}\n")
        with pytest.raises(CaseError, match=r"o.toml: import.level_m = .*: write the storey's "
                                            r"level in metres, a number"):
            load_overlay(overlay)
    overlay.write_text("[import]\nlevel = 3.0\n")
    with pytest.raises(CaseError, match='import.level: unknown field; did you mean "level_m"'):
        load_overlay(overlay)


# -- the routes on models --------------------------------------------------------------------

def _import(tmp_path, overlay_text: str | None = None, **stated):
    """``raised_storey(**stated)`` written and imported; (data, report, level notes)."""
    from cmdp_pymunk.cases.ifc_import import import_storey
    from cmdp_pymunk.cases.ifc_overlay import load_overlay
    from tests import ifc_models

    f, _ = ifc_models.raised_storey("IFC4", **stated)
    path = tmp_path / "m.ifc"
    f.write(str(path))
    overlay = None
    if overlay_text is not None:
        (tmp_path / "o.toml").write_text(overlay_text)
        overlay = load_overlay(tmp_path / "o.toml")
    data, report = import_storey(path, "Level 1", overlay)
    return data, report, [n for n in report.notes if n.startswith('storey "Level 1"')]


SUPPORTS = {"IfcBeam": 4, "IfcColumn": 6, "IfcWall": 1}


def _refused(tmp_path, overlay: str, *model_args, **model_kwargs):
    """The raised storey (``ifc_models.raised_storey(*model_args, **model_kwargs)``) imported
    with ``overlay`` and refused: the error and what the model made."""
    from cmdp_pymunk.cases.ifc_import import import_storey
    from cmdp_pymunk.cases.ifc_overlay import load_overlay
    from tests import ifc_models

    f, made = ifc_models.raised_storey(*model_args, **model_kwargs)
    f.write(str(tmp_path / "m.ifc"))
    (tmp_path / "o.toml").write_text(overlay)
    with pytest.raises(CaseError) as err:
        import_storey(tmp_path / "m.ifc", "Level 1", load_overlay(tmp_path / "o.toml"))
    return err, made


@needs_ifc
@pytest.mark.parametrize("stated, level, route", [
    ({"elevation_m": 3.0}, 3.0, "elevation"),
    # the storey placed 2 m above a building placed at 1 m: 3 m in the world
    ({"placement_m": 3.0, "building_z_m": 1.0}, 3.0, "placement"),
    ({}, 3.3, "slabs"),
])
def test_each_route_finds_the_level_and_the_supports_under_it(tmp_path, stated, level, route):
    """Each route puts the level at the slabs (3 m, their bottoms; or 3.3 m, their tops):
    the 4 beams, 6 columns and the wall below (tops at 3 m) carry the floor; the 4 slabs and
    the wall standing on it (z 3..6) are the components."""
    data, report, notes = _import(tmp_path, **stated)
    assert (report.level_m, report.level_route) == (level, route)
    assert report.supports_by_class == SUPPORTS
    assert report.components_by_class == {"IfcSlab": 4, "IfcWall": 1}
    if route == "slabs":  # an inference: said aloud
        assert notes == [f'storey "Level 1": {describe(3.3, "slabs")}: supports lie below it '
                         "and its elements' heights are checked against it; if that is not "
                         f"the storey's level, {MODEL_FIX}"]
    else:  # the model's word: nothing to say
        assert notes == []


@needs_ifc
def test_the_placement_is_composed_through_the_building_s(tmp_path):
    import ifcopenshell.util.unit

    from cmdp_pymunk.cases.ifc_levels import stated_levels
    from tests import ifc_models

    f, _ = ifc_models.raised_storey("IFC4", placement_m=3.0, building_z_m=1.0)
    storey = f.by_type("IfcBuildingStorey")[0]
    # the storey's own placement says 2000 mm, relative to the building's 1000 mm
    assert storey.ObjectPlacement.RelativePlacement.Location.Coordinates[2] == 2000.0
    assert storey.ObjectPlacement.PlacementRelTo is not None
    assert stated_levels(storey, ifcopenshell.util.unit.calculate_unit_scale(f)) == (None, 3.0)
    storey.Elevation = 2500.0
    assert stated_levels(storey, 0.001) == (2.5, 3.0)


@needs_ifc
def test_an_elevation_that_disagrees_with_the_placement_is_taken_and_noted(tmp_path):
    _, report, notes = _import(tmp_path, elevation_m=3.0, placement_m=0.0)
    assert (report.level_m, report.level_route) == (3.0, "elevation")
    assert report.supports_by_class == SUPPORTS
    assert notes == ['storey "Level 1": level 3.00 m from the storey\'s Elevation (its '
                     "placement says 0.00 m; the Elevation is taken); if the storey is at "
                     f"0.00 m, {ELEVATION_FIX}"]


@needs_ifc
def test_the_overlay_level_is_taken_over_the_model_s_and_noted(tmp_path):
    _, report, notes = _import(tmp_path, "[import]\nlevel_m = 3.0\n")
    assert (report.level_m, report.level_route) == (3.0, "overlay")
    assert notes == ['storey "Level 1": level 3.00 m from the overlay\'s [import] level_m']
    assert report.supports_by_class == SUPPORTS
    _, report, notes = _import(tmp_path, "[import]\nlevel_m = 3.1\n", elevation_m=3.0)
    assert (report.level_m, report.level_route) == (3.1, "overlay")
    assert notes == ['storey "Level 1": level 3.10 m from the overlay\'s [import] level_m (its '
                     "Elevation says 3.00 m; the overlay's is taken)"]


# -- refusals name the level -----------------------------------------------------------------

@needs_ifc
def test_a_wrong_elevation_is_refused_by_the_command_naming_level_and_route(tmp_path, capsys):
    """Elevation 0 on the storey 3 m up, the building's only storey: its range is -2..2 m
    (a nominal 4 m storey). Nothing lies below the level, so no support; the 4 slabs, the 4
    beams (bottoms 2.4 m) and the standing wall (3 m) start above 2 m: 9 elements off the
    storey, each message naming the level, its route and how to set it; exit 2, one message,
    nothing written. The overlay's level_m, as the message says, makes it import."""
    from tests import ifc_models
    from training.commands import import_ifc

    f, made = ifc_models.raised_storey("IFC4", elevation_m=0.0)
    path = tmp_path / "m.ifc"
    f.write(str(path))
    out = tmp_path / "case.toml"
    assert import_ifc.main([str(path), "--storey", "Level 1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cmdp-import-ifc: m.ifc: 9 problem(s) in the case:")
    assert err.count("cmdp-import-ifc:") == 1 and not out.exists()
    assert (f'IfcSlab "S-1" ({made["S-1"].GlobalId}): sits at z 3.00 m (the bottom of its '
            'body), outside storey "Level 1" (level 0.00 m from the storey\'s Elevation: its '
            "elements start from -2.00 m up to 2.00 m), on no storey of the building; fix: "
            "correct its placement in the model (its elevation, or its unit), or take the "
            "storey's elements as assigned with [import] check_storey = false in the overlay; "
            f"if the storey's level is wrong, {ELEVATION_FIX}") in err
    assert err.count("level 0.00 m from the storey's Elevation") == 9
    overlay = tmp_path / "o.toml"
    overlay.write_text('[import]\nlevel_m = "3 m"\n')
    assert import_ifc.main([str(path), "--storey", "Level 1", "--out", str(out),
                            "--overlay", str(overlay)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cmdp-import-ifc: o.toml: 1 problem(s)") and not out.exists()
    assert "import.level_m = '3 m': write the storey's level in metres" in err
    overlay.write_text("[import]\nlevel_m = 3.0\n")
    assert import_ifc.main([str(path), "--storey", "Level 1", "--out", str(out),
                            "--overlay", str(overlay)]) == 0
    printed = capsys.readouterr().out
    assert ("storey \"Level 1\": level 3.00 m from the overlay's [import] level_m (its Elevation "
            "says 0.00 m; the overlay's is taken)") in printed
    assert "4 IfcBeam, 6 IfcColumn, 1 IfcWall" in printed and out.exists()


@needs_ifc
def test_overlaps_of_elements_that_could_carry_the_floor_name_the_level(tmp_path):
    """The wrong Elevation with heights unchecked: nothing lies below level 0, so every
    element is an obstacle, and the 37 overlaps of ``slabs_on_beams`` (counted by hand in
    test_ifc.py) each name the level, its route and how to set it."""

    err, made = _refused(tmp_path, "[import]\ncheck_storey = false\n", "IFC4",
                         elevation_m=0.0)
    assert len(err.value.problems) == 37
    assert all("model it below the storey's level (level 0.00 m from the storey's Elevation; "
               "its top at most 1 mm above it) and list its class in [import] supports in the "
               f"overlay; if the level is wrong, {ELEVATION_FIX}" in p
               for p in err.value.problems)
    assert (f'IfcBeam "B-2" ({made["B-2"].GlobalId}) and IfcBeam "B-X" '
            f'({made["B-X"].GlobalId}): footprints overlap by 0.400 x 0.400 m') in str(err.value)


@needs_ifc
def test_overlaps_on_a_storey_without_any_level_say_how_to_give_it_one(tmp_path):
    """No Elevation, no placement, no slabs in the recipe (beams, columns and walls, as
    precast): no level, no supports. By hand: B-X crosses B-1..B-3 (3); each of B-1..B-3
    meets its 2 columns and the wall below (9); C-1..C-3 the wall below (3): 15 overlaps."""

    err, _ = _refused(tmp_path, '[recipe.classes]\nIfcBeam = "precast"\nIfcColumn = "precast"\n'
                      'IfcWall = "precast"\n[recipe.chains]\n'
                      'precast = [{type = "JC"}, {type = "HI"}, {type = "G"}]\n', "IFC4")
    assert len(err.value.problems) == 15
    assert all("if one carries the other, the storey has no level (neither an Elevation nor a "
               "placement, no slabs to take it from, no [import] level_m in the overlay), so "
               f"nothing is taken as a support: {MODEL_FIX}, with the carrying one below it "
               "and its class in [import] supports in the overlay" in p
               for p in err.value.problems)


@needs_ifc
def test_a_storey_all_below_its_level_names_the_level(tmp_path):
    """Beams only in the recipe, level 3 m from the Elevation: all four lie below it and
    carry the floor, so the storey has nothing on its floor; the refusal says which level."""

    err, _ = _refused(tmp_path, '[recipe.classes]\nIfcBeam = "precast"\n[recipe.chains]\n'
                      'precast = [{type = "JC"}, {type = "HI"}, {type = "G"}]\n',
                      "IFC4", elevation_m=3.0)
    assert ("4 element(s) of it lie below its level 3.00 m from the storey's Elevation and "
            f"carry it ([import] supports; if the level is wrong, {ELEVATION_FIX})"
            ) in str(err.value)


# -- the storey simulates --------------------------------------------------------------

def _run(data: dict, seed: int):
    from agents.navigator import Navigator
    from cmdp_pymunk.cases.load import case_from_dict
    from cmdp_pymunk.engine import Engine
    from cmdp_pymunk.rollout import run_episode

    engine = Engine(case_from_dict(data, "raised"), evaluator="priority")
    episode = run_episode(engine, Navigator(), seed, stall_s=None, progress=False)
    return episode, engine


@needs_ifc
def test_a_storey_with_neither_elevation_nor_placement_imports_and_simulates(tmp_path):
    """The issue's storey: IFC4, no Elevation, no placement, beams (crossing) and columns
    under the slabs. With the default recipe its level comes from the slabs' tops and it
    imports (5 components, 15 tasks) and runs to the end on seed 0."""
    data, report, _ = _import(tmp_path)
    assert report.level_route == "slabs" and report.tasks == 15
    episode, engine = _run(data, seed=0)
    assert episode.makespan_s is not None and engine.site.done


@needs_ifc
@pytest.mark.slow
@pytest.mark.parametrize("seeds", [
    pytest.param(5, id="sample"),  # the slow set (CI): seeds 0-4, about 2 s a floor
    pytest.param(20, marks=pytest.mark.nightly, id="all")])  # before a release: 0-19
def test_the_storey_without_a_level_runs_to_the_end_on_20_seeds(tmp_path, seeds):
    data, _, _ = _import(tmp_path)
    for seed in range(seeds):
        episode, engine = _run(data, seed)
        assert episode.makespan_s is not None and engine.site.done, seed
