"""``cmdp-import-ifc``: a storey of an IFC model as a case file that ``cmdp-simulate`` runs.

    cmdp-import-ifc MODEL.ifc --storey NAME --out floor.toml [--overlay overlay.toml]
    cmdp-import-ifc MODEL.ifc --list-storeys

The storey's elements of the recipe's classes become components (their plan footprints),
tasks come from the recipe (or the model's 4D sequences), crews, crane and storages from the
overlay (defaults fit the built-in case); see ``cmdp_pymunk.cases.ifc_import`` and
docs/ifc.md. The case passes the case check before it is written. Bad input (not an IFC
file, an unknown storey, no elements of the recipe's classes, an element that does not sit
on its storey, overlapping footprints, a cycle in the model's sequences, an overlay naming an
unknown crew or task type) exits with 2 and one message; nothing is written.
Needs the ``[ifc]`` extra: ``pip install -e '.[ifc]'`` in the checkout (``make test`` installs it).
"""

from __future__ import annotations

import argparse
import hashlib
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import cmdp_pymunk
from training.cli import OneLineParser, plain

PROG = "cmdp-import-ifc"


@dataclass(frozen=True)
class ImportArgs:
    """Arguments of ``cmdp-import-ifc`` (see the module doc)."""

    model: Path
    storey: str | None = None
    out: Path | None = None
    overlay: Path | None = None
    list_storeys: bool = False


EPILOG = """\
example, the sample model that ships with the package (the built-in floor as BIM):
  MODEL=$(python -c "import cmdp_pymunk as c; print(c.BUILTIN_CASE.parent / 'precast_floor.ifc')")
  cmdp-import-ifc "$MODEL" --list-storeys                      # Level 1
  cmdp-import-ifc "$MODEL" --storey "Level 1" --out floor.toml
  # cmdp-import-ifc: 36 components (21 IfcBeam, 15 IfcSlab), 87 tasks, 7 crews;
  #   precedences from the recipe -> floor.toml
  cmdp-simulate --case floor.toml --ifc "$MODEL" --out out/bim   # the schedule as 4D too

Crews, crane, storages and margins other than the defaults: --overlay overlay.toml (its
sections and an example: docs/ifc.md). Needs the [ifc] extra: pip install -e '.[ifc]'.
"""


def parse_args(argv: list[str] | None = None) -> ImportArgs:
    # the epilog's example keeps its lines (RawDescriptionHelpFormatter)
    p = OneLineParser(prog=PROG, description=plain(__doc__), epilog=EPILOG,
                      formatter_class=argparse.RawDescriptionHelpFormatter)
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("model", type=Path, help="the IFC model (IFC2X3, IFC4 or IFC4X3)")
    p.add_argument("--storey", help="the IfcBuildingStorey to import, by Name or GlobalId")
    p.add_argument("--out", type=Path, help="the case file to write (TOML)")
    p.add_argument("--overlay", type=Path, default=None,
                   help="crews, crane, storages, margins and recipe (TOML; docs/ifc.md)")
    p.add_argument("--list-storeys", action="store_true", help="list the storeys and exit")
    a = p.parse_args(argv)
    if not a.list_storeys and (a.storey is None or a.out is None):
        p.error("--storey and --out are needed (or --list-storeys)")
    return ImportArgs(a.model, a.storey, a.out, a.overlay, a.list_storeys)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    from cmdp_pymunk.cases.generated import to_toml
    from cmdp_pymunk.cases.ifc_import import import_storey
    from cmdp_pymunk.cases.ifc_model import IfcUnavailable, open_model
    from cmdp_pymunk.cases.ifc_overlay import load_overlay
    from cmdp_pymunk.cases.load import CaseError
    from cmdp_pymunk.events import write_atomic

    try:
        if args.list_storeys:
            from cmdp_pymunk.cases.ifc_storey import storey_names

            for name in storey_names(open_model(args.model)):
                print(name)
            return 0
        overlay = load_overlay(args.overlay)
        data, report = import_storey(args.model, args.storey, overlay)
    except IfcUnavailable as err:
        print(f"{PROG}: {err}", file=sys.stderr)
        return 2
    except CaseError as err:
        print(f"{PROG}: {err}", file=sys.stderr)
        return 2
    header = provenance_header(args, report.provenance, report.crews_left_out)
    write_atomic(args.out, to_toml(data, header))
    classes = ", ".join(f"{n} {c}" for c, n in sorted(report.components_by_class.items()))
    print(f"{PROG}: {len(data['components'])} components ({classes}), {report.tasks} tasks, "
          f"{len(data['crews'])} crews; precedences from the "
          f"{'model' + chr(39) + 's 4D schedule' if report.precedences == 'model' else 'recipe'}"
          f" -> {args.out}")
    if report.supports_by_class:
        print(f"{PROG}: supports (below the storey's level, carrying it; not obstacles): "
              + ", ".join(f"{n} {c}" for c, n in report.supports_by_class.items()))
    if report.skipped_by_class:
        print(f"{PROG}: skipped (not in the recipe): "
              + ", ".join(f"{n} {c}" for c, n in sorted(report.skipped_by_class.items())))
    print(f"{PROG}: settings: {settings_line(report.provenance)}")
    for note in report.notes:
        print(f"{PROG}: note: {note}")
    return 0


def settings_line(provenance: dict[str, str]) -> str:
    """Which settings the overlay gave and which are defaults, in one line: "from the overlay
    site.toml: crews, storages; defaults: crane, import, ..." (the geometry and the elements are
    the model's)."""
    given = [k for k, v in provenance.items() if v != "default"]
    defaults = [k for k, v in provenance.items() if v == "default"]
    parts = []
    if given:
        parts.append(f"from the {provenance[given[0]]}: {', '.join(given)}")
    if defaults:
        parts.append(f"defaults (docs/ifc.md): {', '.join(defaults)}")
    return "; ".join(parts) + "; geometry, elements and units from the model"


def provenance_header(args: ImportArgs, provenance: dict[str, str],
                      crews_left_out: dict[str, int]) -> str:
    """The written case's first comment lines: what it was made from (the model, its SHA-256,
    the storey, the overlay), by which version, and where each setting came from."""
    digest = hashlib.sha256(args.model.read_bytes()).hexdigest()
    lines = [f"Imported from {args.model.name} (SHA-256 {digest[:16]}...), storey "
             f"{args.storey!r}, by {PROG} {cmdp_pymunk.__version__}"
             + (f" with the overlay {args.overlay.name}" if args.overlay else "") + ".",
             "Settings: " + settings_line(provenance) + "."]
    if crews_left_out:
        lines.append("Crews left out (no work on this storey): "
                     + ", ".join(f"{ct} x {n}" for ct, n in crews_left_out.items()) + ".")
    lines += ["Coordinates: metres, origin at the plane's centre. ifc_guid: the element a",
              "component stands for (cmdp-simulate --ifc writes the schedule onto it)."]
    wrapped = [w for line in lines for w in textwrap.wrap(line, 96, break_on_hyphens=False)]
    return "".join(f"# {w}\n" for w in wrapped)


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
