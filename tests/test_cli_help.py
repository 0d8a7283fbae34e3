"""Command-line wording: one message for a count below 1 (``--episodes 0`` and ``-2``), and
``cmdp-import-ifc --help``'s worked example, which is run here as written."""

from __future__ import annotations

import re
import shlex

import pytest

import cmdp_pymunk
from training.commands import import_ifc, simulate


def _usage_error(main, argv, capsys) -> str:
    with pytest.raises(SystemExit) as caught:
        main(argv)
    assert caught.value.code == 2
    (line,) = capsys.readouterr().err.splitlines()
    return line


@pytest.mark.parametrize("value", ["0", "-2"])
def test_episodes_below_one_get_one_message(value, capsys):
    line = _usage_error(simulate.main, ["--episodes", value], capsys)
    assert line == (f"cmdp-simulate: argument --episodes: '{value}' must be a whole number of "
                    "at least 1; fix: give e.g. 1; see cmdp-simulate --help")


def test_episodes_zero_and_minus_two_say_the_same_but_the_value(capsys):
    zero = _usage_error(simulate.main, ["--episodes", "0"], capsys)
    minus_two = _usage_error(simulate.main, ["--episodes=-2"], capsys)
    assert zero.replace("'0'", "V") == minus_two.replace("'-2'", "V")
    assert "0 or more" not in zero + minus_two


def test_import_ifc_help_has_a_worked_example(capsys):
    with pytest.raises(SystemExit):
        import_ifc.main(["--help"])
    out = capsys.readouterr().out
    assert 'cmdp-import-ifc "$MODEL" --storey "Level 1" --out floor.toml' in out
    # RawDescriptionHelpFormatter: the example's lines are kept, not refilled into a paragraph
    assert "\n  cmdp-import-ifc \"$MODEL\" --list-storeys" in out


def test_the_import_ifc_example_runs_as_written(tmp_path, capsys, monkeypatch):
    pytest.importorskip("ifcopenshell")
    model = cmdp_pymunk.BUILTIN_CASE.with_name("precast_floor.ifc")
    monkeypatch.chdir(tmp_path)
    lines = import_ifc.EPILOG.splitlines()
    (command,) = [s.strip() for s in lines if "--storey" in s and s.strip().startswith("cmdp-")]
    printed = [s.strip().lstrip("# ") for s in lines if s.strip().startswith("# ")]
    argv = [str(model) if a == "$MODEL" else a for a in shlex.split(command)[1:]]
    assert import_ifc.main(argv) == 0
    first = capsys.readouterr().out.splitlines()[0]
    # the example's comment is the command's first line, wrapped in two
    assert re.sub(r"\s+", " ", first) == "cmdp-import-ifc: " + " ".join(
        p.removeprefix("cmdp-import-ifc: ") for p in printed)
    assert (tmp_path / "floor.toml").is_file()
