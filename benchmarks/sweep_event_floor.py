"""Does every event floor finish? Seeds x strategies x cases on the event floor alone.

    python benchmarks/sweep_event_floor.py [--seeds 0-499] [--cases builtin,disrupted,layouts]
                                           [--workers 2]

Issue 30 asks that every floor the pymunk floor finishes, the event floor finishes too. Each
case runs every strategy that fits it (Eq. 9, nearest, the searched rule; the GA file and the
stage-2 model on the built-in floor and its disrupted variant) on every seed with its
calibration, and the floors that stall or run out of time are listed (seed, strategy, when,
how many tasks had ended): those are the ones to run on the pymunk floor to see whether it
finishes them. Prints a line per case and strategy and the total, with the CPU time.
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor

import cmdp_pymunk
from cmdp_pymunk.cases.load import BUILTIN_CASE, DISRUPTED_CASE
from training.compare import seed_list

LAYOUTS = sorted(p for p in (BUILTIN_CASE.parent / "layouts").glob("*.toml")
                 if not p.name.endswith(".event.toml"))  # calibrations live beside them
EVERY_CASE = ("priority", "nearest", "student:models/searched_rule.json")
BUILT_IN_ONLY = ("ga:models/ga_priorities.json", "models/stage2_evaluator.zip")


def sweep(case_path: str, strategy: str, seeds: list[int]) -> tuple[list, float]:
    """(unfinished floors as (seed, time_s, tasks ended, tasks), CPU seconds)."""
    from agents.specs import make_evaluator
    from cmdp_pymunk.eventfloor import EventFloor, calibration_for

    case = cmdp_pymunk.load_case(case_path)
    floor = EventFloor(case, evaluator=make_evaluator(strategy), stall_s=3600.0,
                       calibration=calibration_for(case, case_path))
    start = time.process_time()
    bad = []
    for seed in seeds:
        floor.reset(seed)
        floor.run()
        if floor.makespan_s is None:
            bad.append((seed, floor.site.time_s, floor.site.tasks_ended, len(floor.site.tasks)))
    return bad, time.process_time() - start


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--seeds", type=seed_list, default=list(range(500)))
    p.add_argument("--cases", default="builtin,disrupted,layouts")
    p.add_argument("--workers", type=int, default=2)
    args = p.parse_args(argv)
    jobs = []
    for name in args.cases.split(","):
        if name == "builtin":
            jobs += [(str(BUILTIN_CASE), s) for s in EVERY_CASE + BUILT_IN_ONLY]
        elif name == "disrupted":
            jobs += [(str(DISRUPTED_CASE), s) for s in EVERY_CASE + BUILT_IN_ONLY[:1]]
        elif name == "layouts":
            jobs += [(str(path), s) for path in LAYOUTS for s in EVERY_CASE]
        else:
            jobs.append((name, "priority"))
    total, cpu, failures = 0, 0.0, []
    with ProcessPoolExecutor(args.workers) as pool:
        futures = [pool.submit(sweep, path, strategy, args.seeds) for path, strategy in jobs]
        for (path, strategy), future in zip(jobs, futures, strict=True):
            bad, seconds = future.result()
            total += len(args.seeds)
            cpu += seconds
            failures += [(path, strategy, *b) for b in bad]
            print(f"{path.rsplit('/', 1)[-1]:<32} {strategy:<36} {len(args.seeds) - len(bad):>4}/"
                  f"{len(args.seeds)} finished, {1000 * seconds / len(args.seeds):.0f} ms a floor",
                  flush=True)
    print(f"\n{total - len(failures)} of {total} floors finished ({cpu:.0f} CPU s)")
    for path, strategy, seed, t, ended, n in failures:
        print(f"  unfinished: {path.rsplit('/', 1)[-1]} {strategy} seed {seed}: stopped at "
              f"{t:,.0f} s with {ended} of {n} tasks ended")


if __name__ == "__main__":
    main()
