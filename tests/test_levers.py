"""Site levers as data and variants of a case (cmdp_pymunk.cases.levers, lever_checks)."""

from __future__ import annotations

import math

import pytest
from conftest import tiny_file_data

from cmdp_pymunk.cases.levers import (
    free_starts,
    make_variant,
    parse_changes,
    parse_variant_option,
    variant_toml,
)
from cmdp_pymunk.cases.load import TINY_CASE, CaseError, case_from_dict, load_case


def tiny_data(**sections) -> dict:
    """The tiny case file's data with ``sections`` put in."""
    return tiny_file_data(**sections)


def test_an_added_crew_starts_at_the_nearest_free_point():
    # The tiny case's RC-1 starts at (-8, 3); an RC disc has radius sqrt(2.4 / pi) = 0.874 m.
    # On the 0.5 m grid anchored there, a new start must be 0.874 + 0.874 + 0.2 = 1.948 m from
    # (-8, 3): (-8, 1) is within 2.574 m of the outlet (-9, 0) (1.5 + 0.874 + 0.2), so the
    # nearest are (-6, 3) and (-8, 5), both 2.0 m away; the tie goes to the lower y: (-6, 3).
    tiny = load_case(TINY_CASE)
    assert free_starts(tiny, "RC", 1) == [(-6.0, 3.0)]
    variant = make_variant(tiny, "crews.RC+1")
    added = variant.case.crews[-1]
    assert (added.id, added.type, added.start_x_m, added.start_y_m) == ("RC-2", "RC", -6.0, 3.0)
    assert variant.name == "RC+1"
    # deterministic: the same variant twice is the same case
    assert make_variant(tiny, "RC+1").case == variant.case


def test_a_variant_is_named_by_its_changes_and_prints_as_a_case_file(tmp_path):
    tiny = load_case(TINY_CASE)
    variant = make_variant(tiny, "RC+1, rebars.reorder_at=0.25, ST-rebars.capacity=1.5")
    assert variant.label == "RC+1, rebars.reorder_at=0.25, ST-rebars.capacity=1.5"
    assert variant.case.materials["rebars"].reorder_at == 0.25
    assert variant.case.storages[0].capacity == 1.5
    assert len(variant.case.crews) == 3 and len(tiny.crews) == 2  # the base is unchanged
    path = tmp_path / "variant.toml"
    path.write_text(variant_toml(variant))
    assert path.read_text().startswith("# Variant 'RC+1, rebars.reorder_at=0.25")
    assert load_case(path) == variant.case


def test_a_crew_fewer_removes_its_types_last_crew_and_counts_are_set():
    data = tiny_data()
    data["crews"].append({"id": "RC-9", "type": "RC", "start_x_m": 6.0, "start_y_m": -3.0})
    case = case_from_dict(data)
    assert [c.id for c in make_variant(case, "crews.RC-1").case.crews] == ["HIC-1", "RC-1"]
    assert [c.id for c in make_variant(case, "crews.RC=1").case.crews] == ["HIC-1", "RC-1"]


@pytest.mark.parametrize("changes, words", [
    ("crews.RCC+1", ['no crew type "RCC"', 'did you mean "RC"?']),
    ("crews.RC-2", ["cannot lose 2", "fix: remove at most 1"]),
    ("rebars.reorder_at=lots", ['"lots" is not a number', "fix:"]),
    ("rebar.reorder_at=0.2", ['no material or storage "rebar"', 'did you mean "rebars"?']),
    ("rebars.reorder=0.2", ['no lever "reorder"', 'did you mean "reorder_at"?']),
    ("RC+1, RC+2", ["RC.count is changed twice", "fix: give it once"]),
    # validated as a case: a reorder point at the capacity, a storage on a component
    ("rebars.reorder_at=1.0", ["reorder_at", "fix: set reorder_at below the capacity"]),
    ("ST-rebars.x_m=-2, ST-rebars.y_m=0", ['overlaps components[0] "P-1"', "fix: move"]),
    ("ST-rebars.spot=0", ["names no candidate spots", "fix:"]),
])
def test_a_bad_variant_is_refused_naming_the_change_and_the_fix(changes, words):
    with pytest.raises(CaseError) as err:
        make_variant(load_case(TINY_CASE), changes, "v")
    text = str(err.value)
    assert text.startswith("variant 'v'") and all(w in text for w in words), text


LEVERS = {"crews": {"RC": {"min": 1, "max": 2}},
          "materials": {"rebars": {"reorder_at": [0.0, 0.5]}},
          "storages": {"ST-rebars": {"spots": [[6.0, 4.5], [6.0, -4.5]], "capacity": [1.0, 2.0]}}}


def test_levers_bound_what_a_variant_may_change():
    case = case_from_dict(tiny_data(levers=LEVERS))
    moved = make_variant(case, "ST-rebars.spot=1, RC+1")
    assert (moved.case.storages[0].x_m, moved.case.storages[0].y_m) == (6.0, -4.5)
    for changes, words in (("RC+2", ["gives 3 RC crew(s), outside", "max = 2"]),
                           ("rebars.reorder_at=0.8",
                            ["0.8 is outside", "reorder_at = [0, 0.5]"]),
                           ("HIC+1", ["names no crews lever for HIC",
                                      "fix: add [levers.crews.HIC]"]),
                           ("ST-rebars.spot=2", ["has 2 spot(s)", "fix: give spot=0 to 1"]),
                           ("ST-rebars.x_m=5", ["gives no region", "fix:"])):
        with pytest.raises(CaseError) as err:
            make_variant(case, changes)
        assert all(w in str(err.value) for w in words), (changes, str(err.value))


def test_lever_starts_are_taken_in_order_before_free_points():
    levers = {"crews": {"RC": {"max": 3, "starts": [[4.0, -3.0]]}}}
    variant = make_variant(case_from_dict(tiny_data(levers=levers)), "RC+2")
    added = [(c.start_x_m, c.start_y_m) for c in variant.case.crews[2:]]
    assert added[0] == (4.0, -3.0)
    others = [(c.start_x_m, c.start_y_m) for c in variant.case.crews[:-1]]
    assert all(math.dist(added[1], p) >= 2 * 0.874 for p in others)


@pytest.mark.parametrize("levers, words", [
    ({"crews": {"RC": {"min": -1, "max": 2}}}, ["levers: crews: RC: min", "fix:"]),
    ({"crews": {"RC": {"min": 3, "max": 2}}}, ["min = 3 is above max = 2", "fix:"]),
    ({"crews": {"RC": {"max": 2, "starts": [[-8.0, 3.0]]}}},
     ["starts[0] (-8, 3) overlaps the start of crew \"RC-1\"", "fix:"]),
    ({"crews": {"RC": {"max": 3, "starts": [[4.0, -3.0], [4.0, -3.0]]}}},
     ["starts[1] (4, -3) overlaps the start of starts[0]", "fix:"]),
    ({"crews": {"RC": {"max": 2, "starts": [[-2.0, 0.0]]}}}, ['lies on component "P-1"']),
    ({"crews": {"RC": {"max": 2, "starts": [[9.9, 0.0]]}}}, ["outside the plane", "fix:"]),
    ({"crews": {"RC": {"min": 2, "max": 3}}}, ["the case has 1 RC crew(s), outside"]),
    ({"materials": {"rebars": {"reorder_at": [0.0, 1.0]}}},
     ['at or above storage "ST-rebars"\'s capacity 1', "fix:"]),
    ({"storages": {"ST-rebars": {"spots": [[-2.0, 0.0]]}}}, ['on component "P-1"', "fix:"]),
    ({"storages": {"ST-rebars": {"region": [-9.0, 0.0, 9.0, 5.5]}}},
     ["lets the storage (4 x 2 m) leave the plane", "fix: shrink"]),
    ({"storages": {"ST-rebarz": {"capacity": [1.0, 2.0]}}}, ['did you mean "ST-rebars"?']),
])
def test_bad_lever_specs_are_refused_when_the_case_loads(levers, words):
    with pytest.raises(CaseError) as err:
        case_from_dict(tiny_data(levers=levers), "tiny.toml")
    text = str(err.value)
    assert text.startswith("tiny.toml") and all(w in text for w in words), text


def test_parse_variant_option_and_changes():
    assert parse_variant_option("more_rc=crews.RC+1,rebars.reorder_at=0.5") == \
        ("more_rc", "crews.RC+1,rebars.reorder_at=0.5")
    with pytest.raises(ValueError, match="is not NAME=CHANGES; fix"):
        parse_variant_option("crews.RC+1")
    tiny = load_case(TINY_CASE)
    labels = [c.label for c in parse_changes(tiny, "RC=2, materials.rebars.crane_lift_quantity=1")]
    assert labels == ["RC=2", "rebars.crane_lift_quantity=1"]


def test_a_crew_of_an_unknown_type_beside_levers_is_the_case_checks_to_report():
    # found by a sweep of broken cases: the lever check read the crew's type and raised a
    # KeyError instead of the case check's CaseError naming the type and the fix
    data = tiny_data(levers={"crews": {"RC": {"max": 2, "starts": [[4.0, -3.0]]}}})
    data["crews"][0]["type"] = "RCX"
    with pytest.raises(CaseError) as err:
        case_from_dict(data, "tiny.toml")
    assert 'unknown crew type "RCX"' in str(err.value) and 'did you mean "RC"?' in str(err.value)
