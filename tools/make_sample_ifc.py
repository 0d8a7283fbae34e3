"""Write the sample IFC model, cmdp_pymunk/cases/precast_floor.ifc: the built-in case's floor
as BIM (docs/ifc.md).

Storey "Level 1" holds the 15 precast components as IfcSlab and the 21 cast-in-place joints
as IfcBeam, 0.3 m thick boxes named by their case ids, the floor's centre at (40, 25) m of
the model's site so that the importer has to centre it. ``cmdp-import-ifc`` gives the built-in
case back from it (tests/test_ifc.py checks). One run gives one file byte for byte (fixed
GlobalIds and time stamp); run it after changing the built-in case (needs the [ifc] extra):

    python tools/make_sample_ifc.py
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import cmdp_pymunk  # noqa: E402
from cmdp_pymunk.cases.ifc_export import model_from_case  # noqa: E402
from cmdp_pymunk.events import write_atomic  # noqa: E402

OUT = ROOT / "cmdp_pymunk" / "cases" / "precast_floor.ifc"
ORIGIN_M = (40.0, 25.0)


def main() -> None:
    case = cmdp_pymunk.load_case()
    model = model_from_case(case, storey="Level 1", origin=ORIGIN_M, seed="precast-floor")
    write_atomic(OUT, model.to_string())
    print(f"wrote {OUT} ({len(case.components)} elements, {OUT.stat().st_size:,} bytes)")


if __name__ == "__main__":
    main()
