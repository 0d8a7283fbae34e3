"""Without the [ifc] extra the rest installs and runs, and the IFC commands say how to
install it (runs with or without IfcOpenShell: its import is made to fail)."""

import sys

import pytest

from training.commands import import_ifc, simulate


@pytest.fixture
def no_ifcopenshell(monkeypatch):
    for name in [m for m in sys.modules if m == "ifcopenshell" or m.startswith("ifcopenshell.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "ifcopenshell", None)  # import ifcopenshell -> ImportError


def test_import_says_how_to_install_the_extra(no_ifcopenshell, tmp_path, capsys):
    out = tmp_path / "c.toml"
    assert import_ifc.main([str(tmp_path / "m.ifc"), "--storey", "L1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "needs IfcOpenShell" in err and "pip install -e '.[ifc]'" in err
    assert not out.exists()


def test_simulate_with_ifc_says_how_to_install_the_extra(no_ifcopenshell, tmp_path, capsys):
    import cmdp_pymunk

    assert simulate.main(["--case", str(cmdp_pymunk.TINY_CASE), "--ifc", str(tmp_path / "m.ifc"),
                          "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    assert "pip install -e '.[ifc]'" in capsys.readouterr().err


def test_the_core_does_not_import_ifcopenshell_at_module_level():
    import ast
    from pathlib import Path

    for path in (Path(simulate.__file__).parents[2] / "cmdp_pymunk").glob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        top = [n for n in tree.body if isinstance(n, (ast.Import, ast.ImportFrom))]
        names = [a.name for n in top if isinstance(n, ast.Import) for a in n.names]
        names += [n.module or "" for n in top if isinstance(n, ast.ImportFrom)]
        assert not any(n.split(".")[0] in {"ifcopenshell", "shapely"} for n in names), path

