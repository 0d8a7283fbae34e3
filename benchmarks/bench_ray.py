"""Episodes per second with local worker processes and with Ray actors on the same cores,
measured in one run, and the scaling of the lookahead teacher's labelling with workers.

    python benchmarks/bench_ray.py [--seeds 4] [--rounds 2] [--label-seeds 4] [--futures 4]
                                   [--cpus 2]

Needs Ray (``pip install -e '.[ray]'``). Part 1: ``cmdp-evaluate``'s episodes (built-in
case, priority heuristic, scripted navigator) on 1 local process, ``--cpus`` local processes
and a Ray started here with ``--cpus`` CPUs (``--cpus`` actors); each measurement starts its
workers (actors are started anew; Ray itself once) and gives each a first job, timed apart
from the measured jobs: the rates are those of warm workers. Part 2: the lookahead teacher's
labelling (``training.research.distill``'s floors, tiny case, 3 candidates x ``--futures`` sampled
futures) with the same three backends. Rounds alternate the order so that a change in the
machine's load hits every backend; the medians and their ratios to 1 local process are
printed, then the two ratios asked for: Ray against local processes on the same cores (Ray's
overhead), and ``--cpus`` workers against 1 (the scaling), for episodes and for labelling.
The results are checked to be the same whatever the backend. On a machine shared with other
jobs the ratios say what the cores gave then, not what they can give.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import cmdp_pymunk
from cmdp_pymunk.report import versions
from training.research.distill_labels import _label_job
from training.runs.backends import open_backend
from training.runs.strategies import episode_job


def _job(runner, which: str, *args):
    """The measured job, or ``warm``: a short sleep, so that every worker gets one and all of
    them start (local processes are spawned on demand), then the measured job on the first
    arguments (its modules imported, its floor built), its result dropped."""
    if which == "warm":
        time.sleep(0.3)
        _job(runner, *args)
        return None
    return {"episode": episode_job, "label": _label_job}[which](runner, *args)


def measure(job: str, runner_args, jobs, workers: int, ray: str | None,
            keep) -> tuple[float, float, list]:
    """Seconds to start the workers (each has run a first job, not counted), jobs per wall
    second after that, and what ``keep`` takes of each result."""
    start = time.perf_counter()
    with open_backend(_job, runner_args, workers, ray) as pool:
        pool.map([("warm", job, *jobs[0])] * workers)
        up = time.perf_counter()
        results = pool.map([(job, *args) for args in jobs])
    return up - start, len(jobs) / (time.perf_counter() - up), [keep(r) for r in results]


def compare(title: str, unit: str, job: str, runner_args, jobs, cpus: int, rounds: int,
            keep) -> dict[str, float]:
    """The median rate of each backend (1 local process, ``cpus`` local processes, Ray with
    ``cpus`` CPUs), printed with its ratio to 1 local process."""
    backends = [("local 1", 1, None), (f"local {cpus}", cpus, None), (f"Ray {cpus}", cpus, "local")]
    speed: dict[str, list[float]] = {name: [] for name, _, _ in backends}
    kept = {}
    for r in range(rounds):
        for name, workers, ray in backends if r % 2 == 0 else backends[::-1]:
            up, rate, kept[name] = measure(job, runner_args, jobs, workers, ray, keep)
            speed[name].append(rate)
            print(f"{title}: round {r}: {name}: {rate:.3f} {unit}/s after {up:.1f} s to "
                  "start the workers", flush=True)
    first = next(iter(kept.values()))
    assert all(k == first for k in kept.values()), f"{title}: the backends disagree"
    base = statistics.median(speed["local 1"])
    print(f"{title}: median " + ", ".join(
        f"{name} {statistics.median(v):.3f} {unit}/s ({statistics.median(v) / base:.2f} x)"
        for name, v in speed.items()))
    return {name: statistics.median(v) for name, v in speed.items()}


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--seeds", type=int, default=4, help="episodes per measurement")
    p.add_argument("--label-seeds", type=int, default=4, help="floors labelled per measurement")
    p.add_argument("--futures", type=int, default=4,
                   help="sampled futures per candidate in the labelling (its work per floor)")
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--cpus", type=int, default=2, help="local processes and Ray CPUs")
    a = p.parse_args(argv)
    import ray  # after the arguments: --version and --help need no Ray

    start = time.perf_counter()
    ray.init(num_cpus=a.cpus, include_dashboard=False, object_store_memory=200 * 1024**2,
             logging_level="WARNING")
    commit = (versions()["commit"] or "unknown")[:7]
    print(f"commit {commit}, {len(os.sched_getaffinity(0))} cores, load "
          f"{os.getloadavg()[0]:.1f}", flush=True)
    print(f"Ray {ray.__version__} started here with {a.cpus} CPUs in "
          f"{time.perf_counter() - start:.1f} s", flush=True)
    try:
        case = cmdp_pymunk.load_case(None)
        n = a.cpus
        episodes = compare("episodes (built-in case)", "episodes", "episode",
                (case, 3600.0, None, False),
                [("priority", "scripted", s) for s in range(a.seeds)], a.cpus, a.rounds,
                lambda row: row["makespan_s"])
        tiny = str(cmdp_pymunk.TINY_CASE)
        labels = compare("labelling (tiny case)", "floors", "label", None,
                         [(tiny, s, 3, a.futures) for s in range(a.label_seeds)], a.cpus,
                         a.rounds,
                         lambda result: (result["seed"], result["makespan_s"],
                                         len(result["rows"])))
        for title, rates in (("episodes", episodes), ("labelling", labels)):
            print(f"{title}: Ray {n} / local {n} = {rates[f'Ray {n}'] / rates[f'local {n}']:.2f}"
                  f" (Ray's overhead on the same {n} cores); local {n} / local 1 = "
                  f"{rates[f'local {n}'] / rates['local 1']:.2f}, Ray {n} / local 1 = "
                  f"{rates[f'Ray {n}'] / rates['local 1']:.2f} (scaling with workers)")
    finally:
        ray.shutdown()


if __name__ == "__main__":
    main()
