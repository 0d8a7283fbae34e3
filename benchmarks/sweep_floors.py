"""Does every floor finish? Seeds x strategies x cases, on the pymunk floor or the event floor.

    python benchmarks/sweep_floors.py [--fidelity pymunk|event] [--seeds 0-499]
        [--cases builtin,disrupted,layouts] [--workers 2] [--out runs/sweep.jsonl]

Issue 31 asks that every floor the generated layouts hold finishes on seeds 0-199 under every
strategy (the pymunk floor, the scripted navigator); issue 30 that every floor the pymunk floor
finishes, the event floor finishes too. Each case runs every strategy that fits it (Eq. 9,
nearest, the searched rule; the GA file and the stage-2 model on the built-in floor and its
disrupted variant) on every seed, the event floor with the case's calibration. The floors
that stall or run out of time are listed (seed, strategy, when, how many tasks had ended,
and on the pymunk floor the stall guard's report).

Work goes in chunks of ``--chunk`` seeds, seed-major (every case and strategy's seeds 0-9,
then 10-19, ...), so a sweep stopped early covers the same seeds everywhere. With ``--out``
every floor is a line of JSON written as it ends, and a rerun with the same file skips the
floors already there (resume after Ctrl-C). Prints a line per chunk with a true total, then a
line per case and strategy and the total, with the CPU time.
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import cmdp_pymunk
from cmdp_pymunk.cases.load import BUILTIN_CASE, DISRUPTED_CASE
from training.cli import seed_list

LAYOUTS = sorted(p for p in (BUILTIN_CASE.parent / "layouts").glob("*.toml")
                 if not p.name.endswith(".event.toml"))  # calibrations live beside them
EVERY_CASE = ("priority", "nearest", "student:models/searched_rule.json")
BUILT_IN_ONLY = ("ga:models/ga_priorities.json", "models/stage2_desired_position.zip")
STALL_S = 3600.0


def sweep(case_path: str, strategy: str, seeds: list[int], fidelity: str) -> list[dict]:
    """One row per seed: {case, strategy, seed, fidelity, makespan_s, time_s, tasks_ended,
    tasks, cpu_s, stalled}; makespan_s None where the floor did not finish."""
    from agents.specs import evaluator_from_spec

    case = cmdp_pymunk.load_case(case_path)
    evaluator = evaluator_from_spec(strategy)
    if fidelity == "event":
        from cmdp_pymunk.eventfloor import EventFloor, calibration_for

        floor = EventFloor(case, evaluator=evaluator, stall_s=STALL_S,
                           calibration=calibration_for(case, case_path))
    else:
        from agents.navigator import Navigator
        from cmdp_pymunk.engine import Engine
        from cmdp_pymunk.rollout import run_episode

        floor = Engine(case, stage=2, evaluator=evaluator, park_idle=True)
        navigator = Navigator()
    rows = []
    for seed in seeds:
        start = time.process_time()
        stalled = None
        if fidelity == "event":
            floor.reset(seed)
            floor.run()
        else:
            stalled = run_episode(floor, navigator, seed, stall_s=STALL_S,
                                  progress=False).stalled
        rows.append({"case": Path(case_path).name, "strategy": strategy, "seed": seed,
                     "fidelity": fidelity, "makespan_s": floor.makespan_s,
                     "time_s": floor.site.time_s, "tasks_ended": floor.site.tasks_ended,
                     "tasks": len(floor.site.tasks), "cpu_s": time.process_time() - start,
                     "stalled": stalled})
    return rows


def jobs_for(cases: str) -> list[tuple[str, str]]:
    jobs = []
    for name in cases.split(","):
        if name == "builtin":
            jobs += [(str(BUILTIN_CASE), s) for s in EVERY_CASE + BUILT_IN_ONLY]
        elif name == "disrupted":
            jobs += [(str(DISRUPTED_CASE), s) for s in EVERY_CASE + BUILT_IN_ONLY[:1]]
        elif name == "layouts":
            jobs += [(str(path), s) for path in LAYOUTS for s in EVERY_CASE]
        else:
            jobs += [(name, s) for s in EVERY_CASE]
    return jobs


def read_rows(path: Path | None) -> list[dict]:
    """The rows of an earlier run of the same sweep (a line cut by Ctrl-C is dropped)."""
    rows = []
    if path is not None and path.exists():
        for line in path.read_text().splitlines():
            try:
                rows.append(json.loads(line))
            except json.JSONDecodeError:
                continue
    return rows


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--fidelity", choices=("pymunk", "event"), default="event")
    p.add_argument("--seeds", type=seed_list, default=list(range(500)))
    p.add_argument("--cases", default="builtin,disrupted,layouts",
                   help="builtin, disrupted, layouts or case paths, comma-separated")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--chunk", type=int, default=10, help="seeds a job (default 10)")
    p.add_argument("--out", type=Path, default=None,
                   help="a JSON line per floor; a rerun skips the floors already there")
    args = p.parse_args(argv)
    done = {(r["case"], r["strategy"], r["seed"]) for r in read_rows(args.out)
            if r["fidelity"] == args.fidelity}
    chunks = [args.seeds[i:i + args.chunk] for i in range(0, len(args.seeds), args.chunk)]
    jobs = []
    for chunk in chunks:  # seed-major: a sweep stopped early covers the same seeds everywhere
        for path, strategy in jobs_for(args.cases):
            todo = [s for s in chunk if (Path(path).name, strategy, s) not in done]
            if todo:
                jobs.append((path, strategy, todo))
    total = sum(len(t) for _, _, t in jobs)
    print(f"{total} floors to run on the {args.fidelity} floor ({len(done)} already in "
          f"{args.out})", flush=True)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
    ran = 0
    with ProcessPoolExecutor(args.workers) as pool:
        futures = [pool.submit(sweep, path, strategy, todo, args.fidelity)
                   for path, strategy, todo in jobs]
        for (path, strategy, todo), future in zip(jobs, futures, strict=True):
            rows = future.result()
            ran += len(rows)
            if args.out is not None:
                with args.out.open("a") as f:
                    f.writelines(json.dumps(r) + "\n" for r in rows)
            bad = sum(r["makespan_s"] is None for r in rows)
            print(f"[{ran}/{total}] {Path(path).name} {strategy} seeds {todo[0]}-{todo[-1]}: "
                  f"{len(rows) - bad} finished", flush=True)
    report(read_rows(args.out) if args.out is not None else
           [r for f in futures for r in f.result()], args.fidelity)


def report(rows: list[dict], fidelity: str) -> None:
    """A line per case and strategy, the total and every floor that did not finish."""
    rows = [r for r in rows if r["fidelity"] == fidelity]
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["case"], r["strategy"]), []).append(r)
    print()
    for (case, strategy), group in groups.items():
        seeds = sorted(r["seed"] for r in group)
        ok = sum(r["makespan_s"] is not None for r in group)
        cpu = sum(r["cpu_s"] for r in group)
        print(f"{case:<32} {strategy:<36} {ok:>4}/{len(group)} finished (seeds {seeds[0]}-"
              f"{seeds[-1]}), {1000 * cpu / len(group):.0f} ms a floor")
    failures = [r for r in rows if r["makespan_s"] is None]
    print(f"\n{len(rows) - len(failures)} of {len(rows)} floors finished on the {fidelity} floor "
          f"({sum(r['cpu_s'] for r in rows):.0f} CPU s)")
    for r in failures:
        print(f"  unfinished: {r['case']} {r['strategy']} seed {r['seed']}: stopped at "
              f"{r['time_s']:,.0f} s with {r['tasks_ended']} of {r['tasks']} tasks ended")


if __name__ == "__main__":
    main()
