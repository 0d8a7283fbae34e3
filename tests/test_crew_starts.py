"""Two crews on one start point are refused when the case loads (``cases/load.py``): one's
start lies inside the other's body, a disc of its crew type's occupation area."""

from __future__ import annotations

import math

import pytest
from conftest import tiny_dict

from cmdp_pymunk.cases.load import (
    BUILTIN_CASE,
    DISRUPTED_CASE,
    REORDER_CASE,
    TINY_CASE,
    CaseError,
    case_from_dict,
    load_case,
)


def refused(data) -> list[str]:
    with pytest.raises(CaseError) as caught:
        case_from_dict(data, "floor.toml")
    assert caught.value.source == "floor.toml"
    return caught.value.problems


def test_two_crews_on_one_point_are_refused_naming_both_and_the_fix():
    d = tiny_dict()
    d["crews"][3].update(start_x_m=-6.0, start_y_m=3.0)  # M-2 onto X-1
    (message,) = [p for p in refused(d) if "one point" in p]
    # XC and MC both occupy 1.0 m2: radius sqrt(1 / pi) = 0.564 m each; 1.13 m keeps them apart
    assert message == ('crews[3] "M-2": starts at (-6, 3), 0.00 m from crews[0] "X-1" at '
                       "(-6, 3), inside one of their bodies (0.56 m and 0.56 m radius): both "
                       "would start on one point; fix: choose a free start point, at least "
                       "0.56 m from the other crew's (1.13 m keeps the bodies apart)")


def test_a_start_inside_the_other_body_is_one_point_an_edge_overlap_is_not():
    r = math.sqrt(1.0 / math.pi)  # XC and MC: 0.5642 m
    d = tiny_dict()
    d["crews"][3].update(start_x_m=-6.0, start_y_m=3.0 - r + 0.01)  # 1 cm inside X-1's body
    assert any("one point" in p for p in refused(d))
    d["crews"][3]["start_y_m"] = 3.0 - r + 0.0005  # within the 1 mm tolerance
    case_from_dict(d)
    # the discs overlap by 0.5 m at the edge: the physics parts them (the IFC importer packs
    # crews 1.67 m apart on a small storey, bodies up to 1.26 m radius)
    d["crews"][3]["start_y_m"] = 3.0 - (2 * r - 0.5)
    case_from_dict(d)
    # the larger body decides: a KC crew (1.5 m2, 0.691 m radius) and an XC 0.6 m apart
    d = tiny_dict()
    d["crews"][1].update(start_x_m=-6.0, start_y_m=3.0 - 0.6)
    assert any('crews[1] "K-1"' in p and "one point" in p for p in refused(d))


def test_a_crew_of_an_unknown_type_is_reported_once_not_as_an_overlap():
    d = tiny_dict()
    d["crews"][3].update(type="QQ", start_x_m=-6.0, start_y_m=3.0)
    problems = refused(d)
    assert not any("one point" in p for p in problems)
    assert any('unknown crew type "QQ"' in p for p in problems)


@pytest.mark.parametrize("path", [BUILTIN_CASE, DISRUPTED_CASE, REORDER_CASE, TINY_CASE],
                         ids=lambda p: p.name)
def test_no_built_in_case_has_crews_on_one_point(path):
    # the generated layouts and the imported sample IFC pass too: tests/test_layouts.py and
    # tests/test_ifc.py load them
    case = load_case(path)  # refused if two crews overlapped
    assert len(case.crews) >= 2
