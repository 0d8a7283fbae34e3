"""Case loading and validation: every problem named with its file, its entry and a fix.

Broken cases are the built-in TOML with one thing changed, so each test shows exactly the
mistake it makes, on real ids.
"""

from __future__ import annotations

import copy
import tomllib
from collections import Counter
from pathlib import Path

import pytest

from cmdp_pymunk.cases.load import BUILTIN_CASE, TINY_CASE, CaseError, case_from_dict, load_case

ROOT = Path(__file__).resolve().parent.parent
BUILTIN = tomllib.loads(BUILTIN_CASE.read_text(encoding="utf-8"))
FILE = "floor.toml"


@pytest.fixture
def floor() -> dict:
    """The built-in case as raw data, to break."""
    return copy.deepcopy(BUILTIN)


def task(data: dict, task_id: str) -> tuple[int, dict]:
    """A task's index in [[tasks]] and its table, by id."""
    return next((i, t) for i, t in enumerate(data["tasks"]) if t["id"] == task_id)


def entry(data: dict, section: str, item_id: str) -> tuple[str, dict]:
    """The label the loader gives a list entry, e.g. ``tasks[45] "R-H-11"``, and its table."""
    i, item = next((i, e) for i, e in enumerate(data[section]) if e["id"] == item_id)
    return f'{section}[{i}] "{item_id}"', item


def problems(data: dict) -> list[str]:
    with pytest.raises(CaseError) as caught:
        case_from_dict(data, FILE)
    err = caught.value
    assert err.source == FILE
    text = str(err)
    assert text.startswith(f"{FILE}: {len(err.problems)} problem(s)")
    assert all(f"  {FILE}: {p}" in text for p in err.problems)  # every line names the file
    return err.problems


def the_problem(data: dict, label: str, *fragments: str) -> str:
    """The single problem of a case with one mistake: it names the entry, says what is wrong
    (``fragments``) and how to fix it."""
    found = problems(data)
    assert len(found) == 1, found
    message = found[0]
    assert message.startswith(f"{label}: "), message
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    assert "; fix: " in message or "; did you mean " in message, message
    return message


# -- reading the file ---------------------------------------------------------------------------

def test_malformed_toml_names_the_line(tmp_path):
    path = tmp_path / FILE
    text = BUILTIN_CASE.read_text(encoding="utf-8").replace("width_m = 54.0", "width_m = = 54.0")
    path.write_text(text, encoding="utf-8")
    line = text.splitlines().index("width_m = = 54.0") + 1
    with pytest.raises(CaseError) as caught:
        load_case(path)
    (message,) = caught.value.problems
    assert caught.value.source == FILE
    assert message.startswith(f"line {line}: malformed TOML")
    assert "'width_m = = 54.0'" in message and "; fix: " in message


def test_missing_file_is_a_case_error_not_a_traceback(tmp_path):
    path = tmp_path / "no-such-case.toml"
    with pytest.raises(CaseError) as caught:
        load_case(path)
    assert "no-such-case.toml" in str(caught.value)
    message = str(caught.value)
    assert "cannot read the file" in message and "fix: check the path" in message


def test_directory_and_non_utf8_file_are_case_errors(tmp_path):
    with pytest.raises(CaseError, match="cannot read the file"):
        load_case(tmp_path)
    path = tmp_path / FILE
    path.write_bytes(b"\xff\xfe[plane]\n")
    with pytest.raises(CaseError, match="not UTF-8 text.*fix: save the file as UTF-8"):
        load_case(path)


def test_the_case_must_be_a_table():
    with pytest.raises(CaseError, match="must be a table of sections; fix:"):
        case_from_dict([], FILE)


# -- field by field -----------------------------------------------------------------------------

def test_missing_required_field(floor):
    label, item = entry(floor, "tasks", "R-H-11")
    del item["component"]
    the_problem(floor, f"{label}: component", "required field missing",
                "fix: add component = ...")


def test_missing_section(floor):
    del floor["plane"]
    the_problem(floor, "plane", "required field missing", "fix: add a [plane] section")


def test_unknown_field_with_did_you_mean(floor):
    label, item = entry(floor, "tasks", "R-H-11")
    item["predecesors"] = item.pop("predecessors")
    the_problem(floor, f"{label}: predecesors", "unknown field", 'did you mean "predecessors"?')


def test_unknown_field_without_a_close_name_lists_the_fields(floor):
    floor["crew_types"]["RC"]["fatigue"] = 0.5
    the_problem(floor, "crew_types.RC: fatigue", "unknown field", "fix: remove it",
                "velocity_m_s")


def test_unknown_section(floor):
    floor["simulaton"] = floor.pop("simulation")
    the_problem(floor, "simulaton", 'did you mean "simulation"?')


@pytest.mark.parametrize("value", ["fast", "0.7"])  # a quoted number is a string too
def test_string_for_a_number(floor, value):
    floor["crew_types"]["RC"]["velocity_m_s"] = value
    the_problem(floor, "crew_types.RC: velocity_m_s", "valid number", f'(got "{value}")',
                "fix: write a number (without quotes)")


def test_other_wrong_types(floor):
    label, item = entry(floor, "components", "P-23")
    item["x_m"] = True
    floor["simulation"]["frontal_rays"] = 12.5
    floor["task_types"]["HI"]["needs_crane"] = "yes"
    _, r_task = entry(floor, "tasks", "R-H-11")
    r_task["predecessors"] = "HI-P-11"
    found = problems(floor)
    assert len(found) == 4, found
    expected = {
        f"{label}: x_m": "fix: write a number",
        "simulation: frontal_rays": "fix: write a whole number",
        "task_types.HI: needs_crane": "fix: write true or false",
        f'{entry(floor, "tasks", "R-H-11")[0]}: predecessors': "fix: write a list",
    }
    for where, fix in expected.items():
        assert any(p.startswith(where + ": ") and fix in p for p in found), (where, found)


# -- references ---------------------------------------------------------------------------------

def test_unknown_crew_type_on_a_crew(floor):
    label, crew = entry(floor, "crews", "RC-2")
    crew["type"] = "RCC"
    the_problem(floor, label, 'unknown crew type "RCC"', 'did you mean "RC"?')


def test_unknown_crew_type_on_a_task_type(floor):
    floor["task_types"]["F"]["crew_type"] = "FCC"
    # one problem: the 21 F tasks are not reported again as having no crew
    the_problem(floor, "task_types.F", 'crew_type names unknown crew type "FCC"',
                'did you mean "FC"?')


def test_unknown_task_type(floor):
    label, item = entry(floor, "tasks", "G-P-23")
    item["type"] = "GR"
    the_problem(floor, label, 'unknown task type "GR"', 'did you mean "G"?')


def test_unknown_task_type_without_a_close_name_lists_the_known(floor):
    label, item = entry(floor, "tasks", "G-P-23")
    item["type"] = "Welding"
    the_problem(floor, label, 'unknown task type "Welding"',
                'fix: use one of "JC", "HI", "G", "R", "F"')


def test_task_on_a_missing_component(floor):
    label, item = entry(floor, "tasks", "F-V-14")
    item["component"] = "V14"
    the_problem(floor, label, 'names component "V14" which does not exist',
                'did you mean "V-14"?')


def test_precedence_names_an_unknown_task(floor):
    label, item = entry(floor, "tasks", "R-H-11")
    assert item["predecessors"] == ["HI-P-11", "HI-P-12"]
    item["predecessors"] = ["HI-P-11", "HI-P12"]
    the_problem(floor, label, 'precedence names unknown task "HI-P12"', 'did you mean "HI-P-12"?')


def test_truncated_predecessor_suggests_the_first_match_in_the_file(floor):
    label, item = entry(floor, "tasks", "G-P-11")
    item["predecessors"] = ["HI-P-1"]
    the_problem(floor, label, 'unknown task "HI-P-1"', 'did you mean "HI-P-11"?')


def test_precedence_cycle_lists_the_cycle(floor):
    i, jc = task(floor, "JC-P-11")
    jc["predecessors"] = ["G-P-11"]  # G-P-11 already waits for HI-P-11, which waits for JC-P-11
    message = the_problem(floor, f'tasks[{i}] "JC-P-11"', "precedence cycle",
                          "fix: remove one of these predecessors")
    assert "JC-P-11 -> HI-P-11 -> G-P-11 -> JC-P-11" in message


def test_task_preceding_itself(floor):
    label, item = entry(floor, "tasks", "F-H-21")
    item["predecessors"].append("F-H-21")
    the_problem(floor, label, "precedes itself", "fix: remove it from predecessors")


def test_task_type_no_crew_performs(floor):
    floor["crews"] = [c for c in floor["crews"] if c["type"] != "GC"]
    label, _ = entry(floor, "tasks", "G-P-11")
    # one problem for the task type, not one per G task
    the_problem(floor, "task_types.G", "no crew performs this task type", '"GC" crew',
                "15 task(s)", label, 'fix: add a [[crews]] entry with type = "GC"')


def test_material_nothing_supplies(floor):
    floor["storages"] = [s for s in floor["storages"] if s["material"] != "templates"]
    the_problem(floor, "task_types.F", 'material "templates" has no storage that supplies it',
                'fix: add a [[storages]] entry with material = "templates"')


def test_material_not_defined(floor):
    floor["task_types"]["R"]["material"] = "rebar"
    the_problem(floor, "task_types.R", 'material "rebar" is not in [materials]',
                'did you mean "rebars"?')


def test_crew_type_with_two_materials(floor):
    # state.CrewState carries one material; a crew type needing two would silently get one
    floor["task_types"]["G"].update(crew_type="RC", material="templates")
    floor["crews"].append({"id": "GC-2", "type": "RC", "start_x_m": -22.0,
                           "start_y_m": 0.0})
    the_problem(floor, "crew_types.RC", "need different materials")


def test_material_quantity_on_a_task_that_needs_none(floor):
    label, item = entry(floor, "tasks", "JC-P-11")
    item["material_quantity"] = 1.0
    the_problem(floor, label, "needs no material")


def test_duplicate_id(floor):
    floor["components"][1]["id"] = floor["components"][0]["id"]
    floor["components"][1]["x_m"] = 0.5 * (floor["components"][0]["x_m"] + 10)  # no overlap
    found = problems(floor)
    assert 'components: id "P-11" is used twice; fix: rename one' in found


# -- geometry -----------------------------------------------------------------------------------

def test_component_outside_the_plane(floor):
    label, comp = entry(floor, "components", "P-15")
    comp["x_m"] = 26.5  # the plane is 54 m wide: x in [-27, 27]; the 2 m slab reaches 27.5
    the_problem(floor, label, "lies outside the plane [-27, 27] x [-18, 18]",
                "fix: move or shrink it")


def test_overlapping_components(floor):
    label, comp = entry(floor, "components", "H-11")
    comp["x_m"] = -19.0  # the joint now covers x -20..-18, over P-11 (x -21..-19)
    found = problems(floor)
    assert len(found) == 1, found
    # x -20..-19 of P-11's -21..-19, y 9.4..10.6 (the joint's 1.2 m) of its 9..11
    assert found[0] == (f'{label}: overlaps components[0] "P-11" by 1.000 x 1.200 m (more '
                        "than the 0.001 m tolerance); fix: move or shrink one of them")


def test_components_that_share_an_edge_within_the_tolerance_load(floor):
    """P-12 moved beside P-11 (x -21..-19), its left edge at -19 less 4e-15 m: the float
    noise that centring a floor adds. Within GEOMETRY_TOLERANCE_M (1 mm), as the importer."""
    from cmdp_pymunk.cases.floorplan import GEOMETRY_TOLERANCE_M, Rect

    assert GEOMETRY_TOLERANCE_M == 0.001
    _, comp = entry(floor, "components", "P-12")
    comp["x_m"] = -18.0 - 4e-15  # the nearest float: -18.000000000000004
    p11, p12 = Rect.centred(-20.0, 10.0, 2.0, 2.0), Rect.centred(comp["x_m"], 10.0, 2.0, 2.0)
    assert 0 < p11.overlap(p12)[0] < 1e-14 and p11.overlap(p12)[1] == 2.0  # strictly, overlap
    case = case_from_dict(floor, FILE)
    assert [c.id for c in case.components][:2] == ["P-11", "P-12"]


def test_an_overlap_of_5_mm_is_refused_with_its_size(floor):
    label, comp = entry(floor, "components", "P-12")
    comp["x_m"] = -18.005  # x -19.005..-17.005: 5 mm into P-11 (x -21..-19), along all 2 m of y
    the_problem(floor, label, 'overlaps components[0] "P-11" by 0.005 x 2.000 m')


def test_an_imported_components_overlap_names_the_globalids_and_the_models_fix(floor):
    """A case from cmdp-import-ifc: the components are named by id and GlobalId (the index of
    a case file nobody wrote helps no one), and the fix is in the BIM model."""
    _, p11 = entry(floor, "components", "P-11")
    _, p12 = entry(floor, "components", "P-12")
    p11["ifc_guid"], p12["ifc_guid"] = "1aaaaaaaaaaaaaaaaaaaaa", "2bbbbbbbbbbbbbbbbbbbbb"
    p12["x_m"] = -18.005
    (message,) = problems(floor)
    assert message.startswith('component "P-12" (IFC GlobalId 2bbbbbbbbbbbbbbbbbbbbb) overlaps '
                              'component "P-11" (IFC GlobalId 1aaaaaaaaaaaaaaaaaaaaa) in plan by '
                              "0.005 x 2.000 m (more than the 0.001 m tolerance); fix: find the "
                              "two elements in the BIM model by GlobalId")
    assert "components[" not in message and "cmdp-import-ifc" in message


def test_outlet_storage_and_crew_outside_the_plane(floor):
    floor["plane"]["outlet_x_m"] = -30.0
    floor["storages"][0]["y_m"] = 17.0
    floor["crews"][0]["start_y_m"] = 18.0
    found = problems(floor)
    assert len(found) == 3, found
    assert found[0].startswith("plane: the outlet (-30, 0) lies outside")
    assert any(p.startswith('storages[0] "ST-rebars": lies outside') for p in found)
    assert any(p.startswith('crews[0] "JCC-1": start (-24.5, 18) is outside') for p in found)


# -- values -------------------------------------------------------------------------------------

@pytest.mark.parametrize("section, name, field", [
    ("crew_types", "JCC", "duration_mean_min"),
    ("crew_types", "RC", "efficiency_mean_per_min"),
    ("crew_types", "HIC", "velocity_m_s"),
    ("crew_types", "FC", "occupation_area_m2"),
    ("materials", "rebars", "acquire_per_min"),
    ("plane", None, "width_m"),
])
@pytest.mark.parametrize("value", [0.0, -1.0])
def test_non_positive_value(floor, section, name, field, value):
    table = floor[section][name] if name else floor[section]
    table[field] = value
    label = f"{section}.{name}" if name else section
    the_problem(floor, f"{label}: {field}", "greater than 0", f"(got {value!r})",
                "fix: use a positive value")


def test_non_positive_task_work(floor):
    label, item = entry(floor, "tasks", "R-V-25")
    item["work"] = 0.0
    the_problem(floor, f"{label}: work", "fix: use a positive value")


@pytest.mark.parametrize("section, name, field, value", [
    ("task_types", "JC", "congestion_index", 1.2),
    ("task_types", "F", "congestion_index", -0.1),
    ("crew_types", "HIC", "invasion_index", 1.5),
    ("crew_types", "GC", "invasion_index", -0.2),
    ("crew_types", "RC", "carry_deceleration", 1.1),
    ("crew_types", "FC", "carry_deceleration", -0.7),
])
def test_index_outside_unit_interval(floor, section, name, field, value):
    floor[section][name][field] = value
    the_problem(floor, f"{section}.{name}: {field}", f"(got {value!r})",
                "an index lies in [0, 1]; use a value from 0 to 1")


def test_storage_congestion_index_outside_unit_interval(floor):
    floor["storages"][2]["congestion_index_full"] = 2.0
    the_problem(floor, 'storages[2] "ST-struts": congestion_index_full', "in [0, 1]")


def test_crew_type_needs_exactly_one_pace(floor):
    floor["crew_types"]["RC"]["duration_mean_min"] = 20.0
    the_problem(floor, "crew_types.RC", "exactly one pace", "fix: give either duration_mean_min")


def test_crew_type_spread_in_the_wrong_kind(floor):
    floor["crew_types"]["GC"]["efficiency_sd_per_min"] = 0.1
    the_problem(floor, "crew_types.GC", "efficiency_sd_per_min does not go with duration_mean_min",
                "fix: give the spread in the same kind as the mean (duration_sd_min)")


def test_no_crews(floor):
    floor["crews"] = []
    the_problem(floor, "crews", "needs at least one entry", "fix: add at least one entry")


# -- all problems at once -----------------------------------------------------------------------

def test_every_problem_is_reported_at_once(floor):
    """Field errors and cross-reference errors come together, each named once."""
    r_label, r_task = entry(floor, "tasks", "R-H-11")
    del r_task["component"]  # 1: field missing
    floor["crew_types"]["RC"]["velocity_m_s"] = "fast"  # 2: wrong type
    floor["task_types"]["JC"]["congestion_index"] = 1.2  # 3: index out of [0, 1]
    g_label, g_task = entry(floor, "tasks", "G-P-12")
    g_task["predecessors"] = ["HI-P12"]  # 4: unknown task
    h_label, h_comp = entry(floor, "components", "H-11")
    h_comp["x_m"] = -19.0  # 5: overlaps P-11
    floor["storages"] = [s for s in floor["storages"] if s["material"] != "templates"]  # 6
    c_label, crew = entry(floor, "crews", "FC-2")
    crew["type"] = "FCC"  # 7: unknown crew type
    found = problems(floor)
    assert len(found) == 7, "\n".join(found)
    starts = [f"{r_label}: component: ", "crew_types.RC: velocity_m_s: ",
              "task_types.JC: congestion_index: ", f"{g_label}: precedence",
              f"{h_label}: overlaps", "task_types.F: material", f"{c_label}: type"]
    for start in starts:
        assert sum(p.startswith(start) for p in found) == 1, (start, found)


def test_an_entry_with_a_field_error_is_not_also_an_unknown_reference(floor):
    # HI-P-11 has a bad field, but it exists: its successors must not call it unknown,
    # and the RC crews must not call their (broken) crew type unknown.
    label, hi = entry(floor, "tasks", "HI-P-11")
    hi["work"] = "one"
    floor["crew_types"]["RC"]["velocity_m_s"] = -0.7
    found = problems(floor)
    assert len(found) == 2, found
    assert any(p.startswith(f"{label}: work: ") for p in found)
    assert any(p.startswith("crew_types.RC: velocity_m_s: ") for p in found)


def test_problems_from_a_file_name_the_file(floor, tmp_path):
    path = tmp_path / "my-floor.toml"
    text = BUILTIN_CASE.read_text(encoding="utf-8").replace('crew_type = "FC"', 'crew_type = "F"')
    path.write_text(text, encoding="utf-8")
    with pytest.raises(CaseError) as caught:
        load_case(path)
    assert str(caught.value).splitlines()[1] == (
        '  my-floor.toml: task_types.F: crew_type names unknown crew type "F"; '
        'did you mean "FC"?')


# -- the built-in case and the documented example ----------------------------------------------

def test_builtin_case_counts():
    case = load_case()
    assert len(case.tasks) == 87
    assert len(case.components) == 36
    assert len(case.crews) == 7
    assert Counter(c.type for c in case.crews) == {"JCC": 1, "HIC": 1, "GC": 1, "RC": 2, "FC": 2}
    kinds = Counter(c.kind for c in case.components)
    assert kinds == {"precast": 15, "cast-in-place": 21}


def test_builtin_case_task_chains():
    case = load_case()
    by_id = {t.id: t for t in case.tasks}
    kind = {c.id: c.kind for c in case.components}
    on = {c.id: [t for t in case.tasks if t.component == c.id] for c in case.components}
    for comp, tasks in on.items():
        types = [t.type for t in tasks]
        if kind[comp] == "precast":
            assert types == ["JC", "HI", "G"], comp
            jc, hi, g = tasks
            assert jc.predecessors == ()
            assert hi.predecessors == (jc.id,) and g.predecessors == (hi.id,)
        else:
            assert types == ["R", "F"], comp
            r, f = tasks
            assert f.predecessors == (r.id,)
            # a joint is reinforced only once the precast components it joins are installed
            assert r.predecessors and all(by_id[p].type == "HI" for p in r.predecessors), r.id


def test_builtin_case_is_what_the_generator_writes(tmp_path, monkeypatch):
    """tools/make_precast_floor.py and the shipped TOML agree."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_precast_floor",
                                                  ROOT / "tools" / "make_precast_floor.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(module, "OUT", tmp_path / "precast_floor.toml")
    module.main()
    assert module.OUT.read_text(encoding="utf-8") == BUILTIN_CASE.read_text(encoding="utf-8")


def test_builtin_case_paper_values():
    """Tables 2-3 and section 5.1, as the case file holds them."""
    case = load_case()
    table2 = {name: (tt.crew_type, tt.area_distance_m, tt.congestion_index, tt.material)
              for name, tt in case.task_types.items()}
    assert table2 == {"JC": ("JCC", 1.2, 0.9, None), "HI": ("HIC", 2.5, 0.4, "struts"),
                      "G": ("GC", 1.1, 0.7, None), "R": ("RC", 1.5, 0.7, "rebars"),
                      "F": ("FC", 2.0, 0.5, "templates")}
    assert case.task_types["HI"].needs_crane
    assert {m: mat.acquire_per_min for m, mat in case.materials.items()} == {
        "struts": 1.0, "rebars": 0.1, "templates": 5.0}
    ct = case.crew_types
    assert [(ct[n].duration_mean_min, ct[n].duration_sd_min) for n in ("JCC", "HIC", "GC")] == [
        (11.8, 1.2), (11.5, 0.6), (5.0, 0.2)]
    assert [(ct[n].efficiency_mean_per_min, ct[n].efficiency_sd_per_min) for n in ("RC", "FC")] \
        == [(0.021, 0.007), (0.495, 0.134)]
    order = ("JCC", "HIC", "GC", "RC", "FC")
    assert [ct[n].occupation_area_m2 for n in order] == [4.0, 5.0, 1.5, 2.4, 3.2]
    assert [ct[n].velocity_m_s for n in order] == [0.4, 0.3, 0.6, 0.7, 0.5]
    assert [ct[n].invasion_index for n in order] == [0.4, 0.5, 0.15, 0.24, 0.32]
    assert (ct["RC"].carry_deceleration, ct["HIC"].carry_deceleration,
            ct["FC"].carry_deceleration) == (0.9, 0.8, 0.7)
    sim = case.simulation
    assert (sim.step_s, sim.frontal_rays, sim.surrounding_rays) == (1.0, 12, 16)
    assert (sim.turning_rate_deg_s, sim.lateral_velocity_m_s) == (30.0, 0.1)


def test_documented_tiny_case_loads():
    case = load_case(TINY_CASE)
    assert (len(case.components), len(case.tasks), len(case.crews)) == (3, 3, 2)
    assert [t.predecessors for t in case.tasks] == [(), ("HI-P-1",), ("HI-P-1",)]


def test_docs_example_is_the_example_file():
    """The TOML printed in docs/case-study.md is the example file less its comments."""
    import re

    text = (ROOT / "docs" / "case-study.md").read_text(encoding="utf-8")
    block = re.search(r"```toml\n(.*?)```", text, re.S)[1]
    printed = case_from_dict(tomllib.loads(block), "case-study.md")
    example = load_case(TINY_CASE)
    assert printed.model_dump(exclude={"case"}) == example.model_dump(exclude={"case"})


def test_a_case_built_in_python_with_tuples_is_checked_too(floor):
    data = {k: tuple(v) if isinstance(v, list) else v for k, v in floor.items()}
    label, crew = entry(floor, "crews", "RC-2")
    crew["type"] = "R"  # the tuple holds the same tables
    assert problems(data) == [f'{label}: type names unknown crew type "R"; did you mean "RC"?']


def test_two_tasks_of_one_crew_type_on_a_component_are_refused(floor):
    from cmdp_pymunk.cases.load import CaseError, case_from_dict

    data = floor
    extra = dict(data["tasks"][0])
    extra["id"] = "JC-P-11-again"
    data["tasks"].append(extra)
    with pytest.raises(CaseError) as err:
        case_from_dict(data, "floor.toml")
    msg = str(err.value)
    assert 'tasks[87] "JC-P-11-again"' in msg and 'already has a task for crew type JCC' in msg
