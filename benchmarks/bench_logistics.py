"""What deciding the logistics is worth (issue 42 item 6): Eq. 9 on the event floor of the built-in
case, paired by seed, under each logistics role (``cmdp_pymunk.logistics``) against ``Never``
(the paper's c7: a lift asked for once a storage is empty).

    PYTHONPATH=. python benchmarks/bench_logistics.py [--seeds 100-139]

Roles: ``never``; ``reorder`` (a fixed reorder point at half a lift, every material: the
reorder floor's); ``crane-idle`` (asked at 3/4, 1/2 and 1/4 of a lift, lifts when the crane has
nothing under way or queued); ``crane-idle-half`` (the same, asked at half a lift only).
Prints the mean makespan with its 95 % interval, the paired difference to ``never`` with its
interval and the ratio of the means (``training.runs.paired``), the paired difference to
``reorder``, and crane waits. One core,
about a second a floor.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass

import cmdp_pymunk
from cmdp_pymunk import add_version_flag
from cmdp_pymunk.eventfloor import EventFloor, calibration_for
from cmdp_pymunk.logistics import CraneIdle, Never, ReorderPoint
from training.cli import seed_list
from training.runs.paired import mean_ci, paired

ROLES = {
    "never": Never,
    "reorder": lambda: ReorderPoint(lifts=0.5),
    "crane-idle": CraneIdle,
    "crane-idle-half": lambda: CraneIdle(shares=(0.5,)),
}


@dataclass
class Args:
    seeds: list[int]
    roles: list[str]


def parse(argv) -> Args:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_version_flag(p)
    p.add_argument("--seeds", default="100-139", help="seeds, e.g. 100-139 (default)")
    p.add_argument("--roles", default=",".join(ROLES),
                   help=f"comma-separated, of {', '.join(ROLES)} (never is always run)")
    a = p.parse_args(argv)
    roles = [r for r in a.roles.split(",") if r]
    unknown = [r for r in roles if r not in ROLES]
    if unknown:
        p.error(f"--roles: unknown {', '.join(unknown)}; fix: choose from {', '.join(ROLES)}")
    return Args(seed_list(a.seeds), ["never"] + [r for r in roles if r != "never"])


def floor_row(case, calibration, role: str, seed: int) -> dict:
    """One event floor under Eq. 9 and ``role``: its makespan and crane waits."""
    floor = EventFloor(case, evaluator="priority", stall_s=3600.0, calibration=calibration,
                       logistics=ROLES[role]())
    floor.reset(seed)
    floor.run()
    crews = floor.site.crews
    return {"seed": seed, "finished": floor.site.done, "makespan_s": floor.makespan_s,
            "crane_waits": sum(c.stats.crane_waits for c in crews),
            "crane_wait_s": sum(c.stats.crane_wait_steps for c in crews)}


def main(argv=None) -> int:
    args = parse(sys.argv[1:] if argv is None else argv)
    case = cmdp_pymunk.load_case(None)
    calibration = calibration_for(case)
    start = time.process_time()
    rows = {r: [floor_row(case, calibration, r, s) for s in args.seeds] for r in args.roles}
    cpu = time.process_time() - start
    print(f"Eq. 9 on the event floor, built-in case, seeds {args.seeds[0]}-{args.seeds[-1]} "
          f"({len(args.seeds)}), {len(args.roles) * len(args.seeds)} floors in {cpu:.1f} s CPU")
    print("| logistics | finished | makespan (s) | vs never, paired (s) | ratio | vs reorder, "
          "paired (s) | crane waits |")
    print("|---|---|---|---|---|---|---|")
    for role, group in rows.items():
        mean, _, ci = mean_ci([r["makespan_s"] for r in group if r["finished"]])
        vs = paired(group, rows["never"])
        waits, _, waits_ci = mean_ci([r["crane_waits"] for r in group])
        diff = "-" if role == "never" else f"{vs['diff_mean_s']:+,.0f} ± {vs['diff_ci95_s']:,.0f}"
        ratio = "-" if role == "never" else f"{vs['ratio']:.3f}"
        to_point = paired(group, rows["reorder"]) if role != "reorder" and "reorder" in rows \
            else None
        point = "-" if to_point is None else \
            f"{to_point['diff_mean_s']:+,.0f} ± {to_point['diff_ci95_s']:,.0f}"
        print(f"| {role} | {sum(r['finished'] for r in group)}/{len(group)} | "
              f"{mean:,.0f} ± {ci:,.0f} | {diff} | {ratio} | {point} | "
              f"{waits:.1f} ± {waits_ci:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
