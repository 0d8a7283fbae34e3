"""Generated floors and the published split of training and held-out test layouts.

The built-in case stays the paper's floor. To measure how a policy does on a floor it never
saw, ``generate_layout(seed)`` draws a precast floor of the same kind from a seed: a grid of
precast components (3-6 columns, 2-4 rows, 10 or 12 m apart; JC -> HI -> G on each), the
cast-in-place joints between neighbours (R -> F, R waiting for the installation of the
components it joins) less 0-2 openings, 5-7 crews (one JCC, HIC and GC, one or two RC and FC)
and the three storages at distinct places along the top and bottom edges. Task and crew
types, materials, quantities and every setting are the built-in case's (Tables 2-3), so a
policy trained there reads the same observation on every layout. Every layout passes the
case check (``case_from_dict``), time limits included, and every lane between a component and
the joint beside it is wider than the widest crew (``lane_width_m``): with 8 m spacing the
lanes were 2 m, narrower than the HIC (2.5 m across) and the JCC (2.3 m), and the stage-1
policy wedged crews in them for hours (9 stalls in 9 episodes on two such layouts), while the
scripted navigator, which plans round them, finished. A site keeps such lanes passable.

The split is published as case files in ``cmdp_pymunk/cases/layouts/`` (``train-K.toml``
from seeds ``TRAIN_SEEDS``, ``test-K.toml`` from ``TEST_SEEDS``) and registered as
``cmdp/GeneratedFloor-trainK-v1`` and ``cmdp/GeneratedFloor-testK-v1``. Train on the first,
report on the second. Rewrite the files after changing a rule (a test checks they match)::

    python tools/make_layouts.py             # writes cmdp_pymunk/cases/layouts/*.toml
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import tomli_w

from .floorplan import PRECAST_RECIPE, StorageSpot, plan_case
from .load import BUILTIN_CASE, case_from_dict

LAYOUT_DIR = Path(__file__).parent / "layouts"
TRAIN_SEEDS = tuple(range(6))
TEST_SEEDS = (1000, 1001, 1002)

MARGIN_X_M = 7.0  # open floor beside the outer components: crews start and leave there
MARGIN_Y_M = 8.0  # room for the storages along the top and bottom edges
PRECAST_M = 2.0
JOINT_LONG_M, JOINT_SHORT_M = 2.0, 1.2
STORAGES = (("ST-rebars", "rebars", 6.0, 3.0, 3.0, 0.5),  # id, material, w, h, capacity, I
            ("ST-templates", "templates", 6.0, 3.0, 80.0, 0.5),
            ("ST-struts", "struts", 5.0, 3.0, 12.0, 0.6))
SLOT_M = 8.0  # storages sit in distinct slots this wide along an edge
SPACINGS_M = (10.0, 12.0)  # between component centres, either axis
LANE_CLEARANCE_M = 0.4  # a lane is at least the widest crew's diameter plus this
TIME_LIMIT_S_PER_TASK = 1000.0  # max_time_s: the built-in case allows 80,000 s for 87 tasks


def layout_files(split: str) -> list[Path]:
    """The published layouts of ``split`` ("train" or "test"), in seed order."""
    seeds = {"train": TRAIN_SEEDS, "test": TEST_SEEDS}[split]
    return [LAYOUT_DIR / f"{split}-{k}.toml" for k in range(len(seeds))]


def lane_width_m(spacing_m: float) -> float:
    """The open lane between a precast component and the joint beside it, along the axis
    in which components are ``spacing_m`` apart (a joint is ``JOINT_LONG_M`` long there)."""
    return (spacing_m - PRECAST_M - JOINT_LONG_M) / 2


def widest_crew_m(crew_types: dict) -> float:
    """The widest crew's diameter (a disc of its occupation area)."""
    return max(2 * math.sqrt(ct["occupation_area_m2"] / math.pi) for ct in crew_types.values())


def generate_layout(seed: int, name: str | None = None) -> dict:
    """A precast floor drawn from ``seed`` as case data (see the module doc).

    Coordinates are metres from the plane's centre; x runs along the width."""
    rng = np.random.default_rng(seed)
    base = tomllib.loads(BUILTIN_CASE.read_text(encoding="utf-8"))
    cols, rows = int(rng.integers(3, 7)), int(rng.integers(2, 5))
    sx, sy = float(rng.choice(SPACINGS_M)), float(rng.choice(SPACINGS_M))
    assert lane_width_m(min(SPACINGS_M)) >= widest_crew_m(base["crew_types"]) + \
        LANE_CLEARANCE_M, "lanes narrower than a crew trap it: raise SPACINGS_M"
    xs = [(c - (cols - 1) / 2) * sx for c in range(cols)]
    ys = [((rows - 1) / 2 - r) * sy for r in range(rows)]
    half_w = (cols - 1) * sx / 2 + MARGIN_X_M
    half_h = (rows - 1) * sy / 2 + MARGIN_Y_M

    crews = [("JCC-1", "JCC"), ("HIC-1", "HIC"), ("GC-1", "GC")]
    crews += [(f"RC-{k + 1}", "RC") for k in range(int(rng.integers(1, 3)))]
    crews += [(f"FC-{k + 1}", "FC") for k in range(int(rng.integers(1, 3)))]

    # storages: distinct slots along the top and bottom edges, clear of the crews' corner
    slots = [(edge, x) for edge in (1, -1)
             for x in np.arange(-half_w + SLOT_M, half_w - SLOT_M / 2 + 1e-9, SLOT_M)]
    picks = rng.choice(len(slots), size=len(STORAGES), replace=False)
    storages = []
    for (sid, material, w, h, capacity, index), pick in zip(STORAGES, picks, strict=True):
        edge, x = slots[int(pick)]
        storages.append(StorageSpot(sid, material, w, h, capacity, index, edge, float(x)))

    precast = {}
    components = []
    for r, y in enumerate(ys):
        for c, x in enumerate(xs):
            pid = f"P-{r + 1}{c + 1}"
            precast[(r, c)] = pid
            components.append({"id": pid, "kind": "precast", "x_m": x, "y_m": y,
                               "width_m": PRECAST_M, "height_m": PRECAST_M})
    joints = []
    for r, y in enumerate(ys):
        for c in range(cols - 1):
            joints.append((f"H-{r + 1}{c + 1}", (xs[c] + xs[c + 1]) / 2, y, JOINT_LONG_M,
                           JOINT_SHORT_M, (precast[(r, c)], precast[(r, c + 1)])))
    for r in range(rows - 1):
        for c, x in enumerate(xs):
            joints.append((f"V-{r + 1}{c + 1}", x, (ys[r] + ys[r + 1]) / 2, JOINT_SHORT_M,
                           JOINT_LONG_M, (precast[(r, c)], precast[(r + 1, c)])))
    openings = rng.choice(len(joints), size=int(rng.integers(0, 3)), replace=False)
    joints = [j for k, j in enumerate(joints) if k not in set(openings.tolist())]
    for jid, x, y, w, h, _ in joints:
        components.append({"id": jid, "kind": "cast-in-place", "x_m": x, "y_m": y,
                           "width_m": w, "height_m": h})
    ends = {jid: joint_ends for jid, *_, joint_ends in joints}
    data = plan_case(name=name or f"generated-{seed}", description="", half_width_m=half_w,
                     half_height_m=half_h, base=base,
                     crane_times={k: base["crane"][k] for k in ("lift_time_s", "assist_time_s")},
                     crews=crews, storages=storages, components=components,
                     recipe=PRECAST_RECIPE, ends=ends,
                     time_limit_s_per_task=TIME_LIMIT_S_PER_TASK)
    data["case"]["description"] = (f"generated layout, seed {seed}: {cols} x {rows} precast "
                                   f"components {sx:g} x {sy:g} m apart, {len(joints)} joints, "
                                   f"{len(crews)} crews, {len(data['tasks'])} tasks")
    return data


# -- TOML -------------------------------------------------------------------------------------

def _plain(v):
    """``v`` with every float rounded to 6 decimals (the files stay short and stable across
    platforms) and tuples as lists; a non-finite number has no place in a case."""
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"{v!r} has no place in a case")
        return round(v, 6)
    return v


def to_toml(data: dict, header: str = "") -> str:
    """Case data as TOML (``tomli_w``), after ``header`` (comment lines). ``tomli_w`` writes a
    list of tables whose entries each fit on a line as an inline array (``crews = [{...}]``)
    ahead of the tables, as TOML requires; any text, newlines and quotes included, reads back
    the same."""
    return header + ("\n" if header else "") + tomli_w.dumps(_plain(data))


def layout_toml(split: str, k: int) -> str:
    """The published file ``{split}-{k}.toml`` as the generator writes it."""
    seed = {"train": TRAIN_SEEDS, "test": TEST_SEEDS}[split][k]
    data = generate_layout(seed, name=f"generated-{split}-{k}")
    case_from_dict(data, f"{split}-{k}.toml")  # every published layout passes the case check
    header = (f"# Generated layout {split}-{k} (seed {seed}) of the published split; written "
              "by\n# `python tools/make_layouts.py` (cmdp_pymunk/cases/generated.py holds the "
              "rules). Do not edit by hand.\n")
    return to_toml(data, header)


def write_split(folder: Path = LAYOUT_DIR) -> list[Path]:
    """Write every layout of the split into ``folder``; returns the files."""
    from ..events import write_atomic

    written = []
    for split, seeds in (("train", TRAIN_SEEDS), ("test", TEST_SEEDS)):
        for k in range(len(seeds)):
            path = folder / f"{split}-{k}.toml"
            write_atomic(path, layout_toml(split, k))
            written.append(path)
    return written


def main(argv: list[str] | None = None) -> int:
    import argparse

    from .. import add_version_flag

    parser = argparse.ArgumentParser(prog="make_layouts.py",
                                     description="Write the published split of generated layouts.")
    add_version_flag(parser)
    parser.add_argument("--out", type=Path, default=LAYOUT_DIR,
                        help=f"folder for the case files (default: {LAYOUT_DIR})")
    args = parser.parse_args(argv)
    for path in write_split(args.out):
        print(f"wrote {path}")
    return 0

