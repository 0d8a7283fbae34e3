"""The event floor against the pymunk floor, per floor, on the same seeds in one run.

    python benchmarks/bench_event_floor.py [--seeds 0-4] [--case FILE] [--evaluator priority]

Each seed runs on the pymunk floor (scripted navigator, the idle jump: ``cmdp-simulate``'s
floor) and on the event floor (the case's calibration); both are timed in this process's CPU
seconds (what one core spends, whatever else the machine runs) and wall seconds. The event
floor's first floor of a case also plans its paths (one Dijkstra per crew radius and goal,
kept for every later floor of the case): it is timed apart and left out of the per-floor
figure. Prints seconds per floor on each, the ratio (issue 30's target: 50 x, under 50 ms a
floor), events per floor and the makespans side by side.

The garbage collector runs as in the commands' worker processes (``runs.base.collect_less``:
what exists frozen, the youngest generation collected every 20,000 allocations), where
``cmdp-simulate``, ``cmdp-evaluate`` and ``cmdp-plan`` play their floors; ``--gc default``
keeps Python's default settings (about 8 % more instructions a floor, callgrind).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import cmdp_pymunk
from agents.navigator import Navigator
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.eventfloor import EventFloor, calibration_for
from cmdp_pymunk.rollout import run_episode
from training.cli import seed_list
from training.runs.base import collect_less


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--seeds", type=seed_list, default=list(range(5)))
    p.add_argument("--case", default=None)
    p.add_argument("--evaluator", default="priority")
    p.add_argument("--gc", choices=("commands", "default"), default="commands",
                   help="the garbage collector as the commands' workers run it (default) or "
                        "Python's default")
    args = p.parse_args(argv)
    if args.gc == "commands":
        collect_less()
    case = cmdp_pymunk.load_case(args.case)
    floor = EventFloor(case, evaluator=args.evaluator, stall_s=3600.0,
                       calibration=calibration_for(case, args.case))
    cpu, wall = time.process_time(), time.perf_counter()
    floor.reset(args.seeds[0])
    floor.run()
    first = (time.process_time() - cpu, time.perf_counter() - wall)
    engine = Engine(case, evaluator=args.evaluator, park_idle=True)
    rows = []
    for seed in args.seeds:
        cpu, wall = time.process_time(), time.perf_counter()
        pymunk = run_episode(engine, Navigator(), seed, 3600.0, progress=False).makespan_s
        p_cpu, p_wall = time.process_time() - cpu, time.perf_counter() - wall
        cpu, wall = time.process_time(), time.perf_counter()
        floor.reset(seed)
        floor.run()
        e_cpu, e_wall = time.process_time() - cpu, time.perf_counter() - wall
        rows.append((seed, pymunk, floor.makespan_s, p_cpu, e_cpu, p_wall, e_wall,
                     floor.spans_run))
        print(f"seed {seed}: pymunk {pymunk or float('nan'):,.0f} s in {p_cpu:.2f} CPU s; "
              f"event {floor.makespan_s or float('nan'):,.0f} s in {1000 * e_cpu:.1f} CPU ms "
              f"({floor.spans_run} events)")
    p_cpu, e_cpu = np.mean([r[3] for r in rows]), np.mean([r[4] for r in rows])
    p_wall, e_wall = np.mean([r[5] for r in rows]), np.mean([r[6] for r in rows])
    print(f"\n{case.case.name}, {len(rows)} seeds, {args.evaluator}:")
    print(f"  pymunk floor: {p_cpu:.3f} CPU s a floor ({p_wall:.3f} s wall)")
    print(f"  event floor:  {1000 * e_cpu:.1f} CPU ms a floor ({1000 * e_wall:.1f} ms wall), "
          f"{np.mean([r[7] for r in rows]):.0f} events; its first floor of the case "
          f"(paths planned) {first[0]:.2f} CPU s")
    print(f"  ratio: {p_cpu / e_cpu:.0f} x in CPU time, {p_wall / e_wall:.0f} x in wall time")


if __name__ == "__main__":
    main()
