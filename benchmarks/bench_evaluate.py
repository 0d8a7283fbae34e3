"""Episodes per second of ``cmdp-evaluate`` with 1 and with 2 worker processes, measured in one
run on the built-in case (priority heuristic, scripted navigator), and their ratio.

    python benchmarks/bench_evaluate.py [--seeds 4] [--rounds 2]

The rounds alternate 1 and 2 workers so that a change in the machine's load hits both; each
measurement includes starting the worker processes (as a ``cmdp-evaluate`` run pays it once).
The episodes are the same either way (``training.runs.runner.Workers`` keeps job order), which is
checked. With other jobs on the cores the ratio falls: it says what this machine gave now.
"""

from __future__ import annotations

import argparse
import statistics
import time

import cmdp_pymunk
from training.runs.backends import Workers
from training.runs.strategies import episode_job


def measure(case, seeds: list[int], workers: int) -> tuple[float, list]:
    """Episodes per wall second, and the makespans."""
    start = time.perf_counter()
    with Workers(episode_job, (case, 3600.0, None, False), workers) as pool:
        rows = pool.map([("priority", "scripted", s) for s in seeds])
    return len(seeds) / (time.perf_counter() - start), [r["makespan_s"] for r in rows]


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--seeds", type=int, default=4, help="episodes per measurement")
    p.add_argument("--rounds", type=int, default=2)
    a = p.parse_args(argv)
    case = cmdp_pymunk.load_case(None)
    seeds = list(range(a.seeds))
    speed: dict[int, list[float]] = {1: [], 2: []}
    makespans = {}
    for r in range(a.rounds):
        for workers in (1, 2) if r % 2 == 0 else (2, 1):
            eps, makespans[workers] = measure(case, seeds, workers)
            speed[workers].append(eps)
            print(f"round {r}: {workers} worker(s): {eps:.3f} episodes/s")
    assert makespans[1] == makespans[2], "workers changed the episodes"
    one, two = statistics.median(speed[1]), statistics.median(speed[2])
    print(f"median: 1 worker {one:.3f}, 2 workers {two:.3f} episodes/s; ratio {two / one:.2f}")


if __name__ == "__main__":
    main()
