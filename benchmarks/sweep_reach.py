"""One reach rule (issue 41 item 3): does every floor the case check passes finish, and does a
floor the check refuses fail to? Generated layouts, the floors of tests/test_reach_rule.py and
the imported storeys of tests/ifc_models.py, under the priority heuristic (Eq. 9) and the other
cheap strategies (``--strategies all``: every name of ``evaluate.EVALUATORS``), on seeds
0..N-1, on either floor.

    PYTHONPATH=. python benchmarks/sweep_reach.py [--fidelity pymunk|event] [--seeds 3|10-19]
        [--layouts 6] [--strategies priority,nearest|all] [--no-ifc] [--floors edge,fenced]

A floor the check refuses is run anyway (the check bypassed) and counted as "refused but
finished" if it ends every task: that is a refusal the rule should not make. Prints a line per
floor and strategy (finished / stalled seeds, the mean makespan, the seconds it took) and the
totals: the claim is 0 stalls among the floors that load and 0 refused floors that finish, on
both floors (the event floor's walks end where the check counts a task reached:
``eventfloor.walks``).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path
from unittest import mock

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

from cmdp_pymunk import add_version_flag  # noqa: E402 (the checkout first on the path)

STALL_S = 3600.0


def floors(layouts: int, ifc: bool, wanted: list[str] = ()) -> list[tuple[str, dict]]:
    """(name, case data) of every floor swept (only those whose name holds a part of
    ``wanted``, if any: an IFC model takes seconds to write and import)."""
    from test_reach_rule import fenced_slabs, isolated_joints

    from cmdp_pymunk.cases.generated import generate_layout

    out = [(f"layout-{seed}", generate_layout(seed)) for seed in range(layouts)]
    out += [("isolated-joints-2.0", isolated_joints(2.0)),
            ("isolated-joints-1.8", isolated_joints(1.8)),
            ("fenced-slabs-corners-open", fenced_slabs(corners_open=True)),
            ("fenced-slabs", fenced_slabs(corners_open=False))]
    if ifc:
        try:
            import ifc_models

            from cmdp_pymunk.cases.ifc_import import import_storey
        except ImportError as err:  # the [ifc] extra is optional
            print(f"imported storeys skipped: {err}")
            return out
        models = [(name, getattr(ifc_models, name), {}) for name in
                  ("two_by_two", "slabs_on_beams", "wide_slab_deck", "l_storey", "precast_deck",
                   "notched_wide_slab_deck")]
        # the storey with no level (its slabs' tops), and the IFC2X3 storey with a beam along
        # a slab's edge, open and closed (tests/test_ifc2x3_edge.py)
        models += [("raised_storey", ifc_models.raised_storey, {}),
                   ("edge_beam_storey", ifc_models.edge_beam_storey, {"schema": "IFC2X3"}),
                   ("edge_beam_storey-closed", ifc_models.edge_beam_storey,
                    {"schema": "IFC2X3", "closed": True})]
        with tempfile.TemporaryDirectory() as tmp:
            for name, make, kwargs in models:
                if wanted and not any(part in f"ifc-{name}" for part in wanted):
                    continue
                made = make(**kwargs)
                model = made[0] if isinstance(made, tuple) else made
                path = Path(tmp) / f"{name}.ifc"
                model.write(str(path))
                with mock.patch("cmdp_pymunk.cases.load.unreachable", lambda case: []):
                    data, _ = import_storey(path, "Level 1")
                out.append((f"ifc-{name}", data))
    return out


def _seeds(text: str):
    """``--seeds``: a bare number N is seeds 0..N-1 (as before); else ``training.cli.seed_list``
    (``10-19``, ``0,3,5``), to extend a sweep past the seeds already run."""
    from training.cli import seed_list

    return range(int(text)) if text.isdigit() else seed_list(text)


def run(data: dict, strategy: str, seeds, fidelity: str) -> list[dict]:
    """One row per seed: makespan_s (None: not finished), stalled, tasks ended of tasks."""
    import cmdp_pymunk.cases.load as load
    from agents.navigator import Navigator
    from cmdp_pymunk.eventfloor.floor import make_floor
    from cmdp_pymunk.rollout import run_episode

    with mock.patch.object(load, "unreachable", lambda case: []):  # run refused floors too
        case = load.case_from_dict(data, "sweep")
    rows = []
    for seed in seeds:
        floor = make_floor(case, fidelity, evaluator=strategy)
        episode = run_episode(floor, Navigator(), seed, stall_s=STALL_S, progress=False)
        rows.append({"seed": seed, "makespan_s": episode.makespan_s,
                     "stalled": episode.stalled is not None,
                     "ended": floor.site.tasks_ended, "tasks": len(floor.site.tasks)})
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_version_flag(p)
    p.add_argument("--fidelity", default="pymunk", choices=("pymunk", "event"))
    p.add_argument("--seeds", type=_seeds, default=range(3),
                   help="seeds 0..N-1 for a number N, or a list or range, e.g. 10-19")
    p.add_argument("--layouts", type=int, default=6, help="generated layouts, seeds 0..K-1")
    p.add_argument("--strategies", default="priority,nearest",
                   help="comma-separated evaluator names, or all (every one of "
                        "evaluate.EVALUATORS)")
    p.add_argument("--no-ifc", action="store_true", help="leave out the imported storeys")
    p.add_argument("--floors", default="",
                   help="comma-separated parts of floor names: sweep only those floors")
    a = p.parse_args(argv)
    from cmdp_pymunk.cases.load import CaseError, case_from_dict
    from cmdp_pymunk.evaluate import EVALUATORS

    strategies = list(EVALUATORS) if a.strategies == "all" else a.strategies.split(",")
    start = time.perf_counter()
    totals = {"loads": 0, "stalled": 0, "refused": 0, "refused_finished": 0}
    wanted = [part for part in a.floors.split(",") if part]
    for name, data in floors(a.layouts, not a.no_ifc, wanted):
        if wanted and not any(part in name for part in wanted):
            continue
        try:
            case_from_dict(data, name)
            verdict = "loads"
        except CaseError as err:
            verdict = "refused"
            first = str(err).splitlines()[1].strip() if "\n" in str(err) else str(err)
        for strategy in strategies:
            began = time.perf_counter()
            rows = run(data, strategy, a.seeds, a.fidelity)
            done = [r["makespan_s"] for r in rows if r["makespan_s"] is not None]
            bad = [r for r in rows if r["makespan_s"] is None]
            mean = f"{statistics.mean(done):,.0f} s" if done else "-"
            shown = "".join(f"; seed {r['seed']}: {r['ended']}/{r['tasks']}"
                            f"{' stalled' if r['stalled'] else ''}" for r in bad[:3])
            if len(bad) > 3:  # a refused floor stalls on every seed: the first few say how
                shown += f"; {len(bad) - 3} more"
            print(f"{name:30s} {verdict:8s} {strategy:9s} finished {len(done)}/{len(rows)}"
                  f" (mean {mean}; {time.perf_counter() - began:,.0f} s){shown}", flush=True)
            if verdict == "loads":
                totals["loads"] += len(rows)
                totals["stalled"] += len(bad)
            else:
                totals["refused"] += len(rows)
                totals["refused_finished"] += len(done)
        if verdict == "refused":
            print(f"    refused: {first[:200]}")
    print(f"{a.fidelity}: {totals['loads']} runs of floors that load, {totals['stalled']} not "
          f"finished; {totals['refused']} runs of refused floors, {totals['refused_finished']} "
          f"finished; {time.perf_counter() - start:,.0f} s")
    return 0 if totals["stalled"] == 0 and totals["refused_finished"] == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
