"""The split of cases/ifc_import.py (issue 43): its parts apart, none needing IfcOpenShell to be
imported, and the names the docs gave as ``cmdp_pymunk.cases.ifc_import.X`` still there.
Runs with or without the [ifc] extra."""

import ast
import subprocess
import sys
from pathlib import Path

from cmdp_pymunk.cases import ifc_import, ifc_model, ifc_overlay, ifc_schedule, ifc_storey

IFC_MODULES = (ifc_import, ifc_model, ifc_overlay, ifc_schedule, ifc_storey)


def test_ifc_import_still_offers_the_names_it_documented():
    """docs/api/ifc.md and the commands named these ``cases.ifc_import.X``: each is still
    there, and is the moved object itself, not a copy that could drift."""
    moved = {"IfcUnavailable": ifc_model, "open_model": ifc_model, "load_overlay": ifc_overlay,
             "Overlay": ifc_overlay, "storey_names": ifc_storey}
    assert set(moved) <= set(ifc_import.__all__)
    for name, module in moved.items():
        assert getattr(ifc_import, name) is getattr(module, name), name
        assert getattr(module, name).__module__ == module.__name__, name
    for name in ("import_storey", "ImportReport", "build_case"):  # the case stays here
        assert getattr(ifc_import, name).__module__ == ifc_import.__name__, name


def test_no_ifc_module_imports_ifcopenshell_at_its_top():
    """IfcOpenShell (and shapely, for the footprints) is imported inside the functions that
    need it: the statements at each module's top name neither."""
    for module in IFC_MODULES:
        tree = ast.parse(Path(module.__file__).read_text(encoding="utf-8"))
        top = [n for n in tree.body if isinstance(n, (ast.Import, ast.ImportFrom))]
        names = [a.name for n in top if isinstance(n, ast.Import) for a in n.names]
        names += [n.module or "" for n in top if isinstance(n, ast.ImportFrom)]
        assert not {n.split(".")[0] for n in names} & {"ifcopenshell", "shapely"}, module


def test_every_ifc_module_imports_without_ifcopenshell():
    """In a fresh interpreter where ``import ifcopenshell`` fails, the IFC modules and the
    import command load; the first function that needs IfcOpenShell says how to install it."""
    code = (
        "import sys\n"
        "sys.modules['ifcopenshell'] = None\n"
        "import cmdp_pymunk.cases.ifc_export, cmdp_pymunk.cases.ifc_import\n"
        "import training.commands.import_ifc\n"
        "from cmdp_pymunk.cases.ifc_model import IfcUnavailable, require_ifcopenshell\n"
        "try:\n"
        "    require_ifcopenshell()\n"
        "except IfcUnavailable as err:\n"
        "    print(err)\n")
    root = Path(__file__).resolve().parent.parent
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=root, env={"PYTHONPATH": str(root), "PATH": ""}, timeout=60)
    assert out.returncode == 0, out.stderr
    assert "needs IfcOpenShell" in out.stdout and "pip install -e '.[ifc]'" in out.stdout
