"""Case validation of what used to get through and stall: geometry that traps a crew or a
storage, NaN and infinite numbers, and times so large that no episode could finish."""

from __future__ import annotations

import copy
import math
import tomllib

import pytest

from cmdp_pymunk.cases.load import BUILTIN_CASE, CaseError, case_from_dict

BUILTIN = tomllib.loads(BUILTIN_CASE.read_text(encoding="utf-8"))
FILE = "floor.toml"


@pytest.fixture
def floor() -> dict:
    return copy.deepcopy(BUILTIN)


def the_problem(data: dict, start: str, *fragments: str) -> str:
    with pytest.raises(CaseError) as caught:
        case_from_dict(data, FILE)
    found = caught.value.problems
    assert len(found) == 1, found
    assert found[0].startswith(start), found[0]
    for fragment in fragments:
        assert fragment in found[0], (fragment, found[0])
    assert "; fix: " in found[0]
    assert f"{FILE}: {found[0]}" in str(caught.value)
    return found[0]


def component(data: dict, comp_id: str) -> tuple[int, dict]:
    return next((i, c) for i, c in enumerate(data["components"]) if c["id"] == comp_id)


def test_storage_on_a_component(floor):
    j, comp = component(floor, "P-11")
    floor["storages"][2].update(x_m=comp["x_m"], y_m=comp["y_m"])
    the_problem(floor, 'storages[2] "ST-struts": overlaps', f'components[{j}] "P-11"',
                "move the storage off the component")


def test_crew_starting_inside_a_component(floor):
    j, comp = component(floor, "P-11")
    floor["crews"][1].update(start_x_m=comp["x_m"], start_y_m=comp["y_m"])
    the_problem(floor, 'crews[1] "HIC-1": start', f'inside components[{j}] "P-11"',
                "open floor")


def test_outlet_inside_a_component(floor):
    j, comp = component(floor, "P-11")
    floor["plane"].update(outlet_x_m=comp["x_m"], outlet_y_m=comp["y_m"])
    the_problem(floor, "plane: the outlet", f'inside components[{j}] "P-11"')


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_nan_and_infinite_coordinates(floor, value):
    floor["crews"][0]["start_x_m"] = value
    the_problem(floor, 'crews[0] "JCC-1": start_x_m', "finite number", "not nan or inf")


def test_infinite_time_limit(floor):
    floor["simulation"]["max_time_s"] = math.inf
    the_problem(floor, "simulation: max_time_s", "finite number")


def test_a_crane_lift_longer_than_the_time_limit(floor):
    floor["crane"]["lift_time_s"] = 1e308
    the_problem(floor, "crane: lift_time_s = 1e+308 s", "no episode could finish")


def test_a_task_longer_than_the_time_limit(floor):
    i, t = next((i, t) for i, t in enumerate(floor["tasks"]) if t["id"] == "F-H-34")
    t["work"] = 1e9
    the_problem(floor, f'tasks[{i}] "F-H-34": its expected duration', "no episode could finish")


def test_a_crew_too_slow_to_cross_the_plane(floor):
    floor["crew_types"]["GC"]["velocity_m_s"] = 1e-4  # 90 m at 0.1 mm/s: 900,000 s
    the_problem(floor, "crew_types.GC: velocity_m_s", "no episode could finish")


def test_a_time_limit_below_the_lower_bound(floor):
    floor["simulation"]["max_time_s"] = 10000.0  # the lower bound is 15,273 s
    the_problem(floor, "simulation: max_time_s = 10000 s is below the makespan lower bound "
                       "of 15273 s", "raise max_time_s")


def test_crane_busy_beyond_the_time_limit(floor):
    floor["crane"]["lift_time_s"] = 5000.0  # each lift fits, but the floor needs dozens
    the_problem(floor, "crane: its lifts and assistance add up to", "crane_lift_quantity")


def test_the_simulate_command_refuses_them_with_exit_2(tmp_path, capsys):
    from training.commands import simulate

    text = BUILTIN_CASE.read_text(encoding="utf-8").replace(
        "max_time_s = 80000.0", "max_time_s = inf", 1)
    assert "max_time_s = inf" in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text, encoding="utf-8")
    assert simulate.main(["--case", str(bad), "--out", str(tmp_path / "o"),
                          "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "bad.toml: simulation: max_time_s" in err and "Traceback" not in err


@pytest.mark.parametrize("argv", [["--max-time-s", "inf"], ["--max-time-s", "nan"],
                                  ["--stall-s", "nan"], ["--stall-s", "-5"],
                                  ["--max-time-s", "0"], ["--seed", "-1"],
                                  ["--episodes", "0"], ["--stall-s", "1e999"]])
def test_bad_numbers_on_the_command_line_get_one_line_and_exit_2(argv, tmp_path, capsys):
    from training.commands import simulate

    with pytest.raises(SystemExit) as caught:
        simulate.main([*argv, "--out", str(tmp_path / "o")])
    assert caught.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"argument {argv[0]}: " in err, err
