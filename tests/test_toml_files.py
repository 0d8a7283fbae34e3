"""TOML in and out: the case writer and the calibration writer (tomli-w) write any name so that
it reads back the same, and a syntax error reads the same in a case file and an IFC overlay."""

from __future__ import annotations

import tomllib

import pytest
from conftest import tiny_dict

from cmdp_pymunk.cases.generated import to_toml
from cmdp_pymunk.cases.ifc_overlay import load_overlay
from cmdp_pymunk.cases.load import CaseError, case_from_dict, load_case
from cmdp_pymunk.eventfloor.calibration import (
    Calibration,
    CrewTypeCalibration,
    fingerprint,
    load_calibration,
    write_calibration,
)

# what a hand-written writer got wrong: a newline ends a basic string, a quote or a backslash
# ends or escapes it, a tab and a control character need escapes, "#" would start a comment
AWKWARD = 'two\nlines, a "quote", a back\\slash, a\ttab, a bell \x07 and # not a comment'


def test_a_case_with_awkward_names_reads_back_the_same():
    data = tiny_dict()
    data["case"]["name"] = AWKWARD
    data["case"]["description"] = "line one\nline two\n"
    data["crew_types"]["XC"]["name"] = AWKWARD
    text = to_toml(data, "# a header\n")
    assert text.startswith("# a header\n\n")
    back = tomllib.loads(text)
    assert back["case"]["name"] == AWKWARD
    assert back["crew_types"]["XC"]["name"] == AWKWARD
    assert case_from_dict(back) == case_from_dict(data)


def test_the_case_writer_rounds_floats_and_refuses_non_finite_ones():
    data = tiny_dict()
    data["crews"][0]["start_x_m"] = -6.0000004  # rounded to 6 decimals
    assert tomllib.loads(to_toml(data))["crews"][0]["start_x_m"] == -6.0
    data["crews"][0]["start_x_m"] = float("nan")
    with pytest.raises(ValueError, match="has no place in a case"):
        to_toml(data)


def test_a_calibration_with_awkward_text_reads_back_the_same(tmp_path):
    case = load_case(None)
    cal = Calibration(case=AWKWARD, fingerprint=fingerprint(case), fitted_on="seeds 0-3\nagain",
                      command='cmdp-calibrate --out "my floor.event.toml"',
                      crew_types={"RC": CrewTypeCalibration(walk_factor=1.23456, dock_s=7.5)})
    path = write_calibration(cal, tmp_path / "c.event.toml")
    back = load_calibration(path, case)
    assert (back.case, back.fitted_on, back.command) == (cal.case, cal.fitted_on, cal.command)
    # the fitted numbers are written to 4 decimals: 1.23456 -> 1.2346
    assert back.crew_types["RC"] == CrewTypeCalibration(walk_factor=1.2346, dock_s=7.5)
    assert path.read_text(encoding="utf-8").startswith("# The event floor's calibration")
    assert [p.name for p in tmp_path.iterdir()] == ["c.event.toml"]  # no temporary left


# -- a syntax error reads the same in a case file and in an overlay ------------------------------

BROKEN = "[plane]\nmargin_x_m = = 6.0\n"


def _problem(load, path):
    with pytest.raises(CaseError) as caught:
        load(path)
    return caught.value.source, caught.value.problems


@pytest.mark.parametrize("load", [load_case, load_overlay], ids=["case", "overlay"])
def test_a_toml_syntax_error_names_the_file_the_line_and_the_fix(tmp_path, load):
    path = tmp_path / "site.toml"
    path.write_text(BROKEN, encoding="utf-8")
    source, (message,) = _problem(load, path)
    assert source == "site.toml"
    assert message.startswith("line 2: malformed TOML: ")
    assert "'margin_x_m = = 6.0'" in message
    assert message.endswith("; fix: correct the syntax on that line")


def test_a_case_file_and_an_overlay_report_one_error_word_for_word(tmp_path):
    path = tmp_path / "site.toml"
    path.write_text(BROKEN, encoding="utf-8")
    assert _problem(load_case, path) == _problem(load_overlay, path)
    missing = tmp_path / "nowhere.toml"
    assert _problem(load_case, missing) == _problem(load_overlay, missing)
    path.write_bytes(b"\xff\xfe[plane]\n")
    assert _problem(load_case, path) == _problem(load_overlay, path)
