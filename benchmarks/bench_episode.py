"""One whole episode on the built-in case (priority heuristic, no GIF): simulated seconds per
second, and the split between physics, rays, decisions and navigation, measured in one run.

    python benchmarks/bench_episode.py [--seed 0] [--navigator models/stage1_reaching.zip]

With ``--navigator MODEL.zip`` the same seed also runs with that reaching policy as the low
level (sampled actions, as ``cmdp-simulate --stochastic``; every crew decides, as in the paper),
and the policy floor's speed is printed as a ratio to the scripted navigator's in this run.

Speeds are given against wall time and against this process's CPU time: the CPU time is what
one core spends whatever else the machine runs (the wall-clock figure falls when other jobs
share the cores). Targets (issue 9): 20,000 x real time with the scripted navigator and
8,000 x with the stage-1 policy, on one core.
"""

from __future__ import annotations

import argparse
import time

import cmdp_pymunk
from agents.navigator import Navigator
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.evaluate import PriorityEvaluator
from cmdp_pymunk.observe import ReachingObservations
from cmdp_pymunk.timing import StageClock, clocked


def run(seed: int, navigator_path: str | None, park: bool):
    """One episode: (engine, step calls, wall s, CPU s, stage clock)."""
    engine = Engine(cmdp_pymunk.load_case(None), evaluator=PriorityEvaluator(),
                    park_idle=park and navigator_path is None)
    if navigator_path is None:
        navigator = Navigator()
    else:
        from agents.models import PolicyNavigator

        navigator = PolicyNavigator(navigator_path, deterministic=False)
    clock = StageClock()
    clocked(engine, clock)
    engine.reset(seed)
    navigator.reset(seed)
    reaching = ReachingObservations(engine.case) if navigator.reads_rays else None
    n, calls = len(engine.case.crews), 0
    start, cpu = time.perf_counter(), time.process_time()
    while True:
        t0 = time.perf_counter()
        observations = [reaching.crew(engine, i) for i in range(n)] if reaching else None
        t1 = time.perf_counter()
        actions = navigator.actions(engine, observations)
        clock.seconds["rays (Eq. 3)"] += t1 - t0
        clock.seconds["navigation"] += time.perf_counter() - t1
        run = engine.advance(actions, until=engine.decision_due)
        calls += 1
        if run.terminated or run.truncated:
            break
    return engine, calls, time.perf_counter() - start, time.process_time() - cpu, clock


def report(label: str, engine, calls: int, wall: float, cpu: float, clock) -> float:
    sim = engine.site.time_s
    end = f"makespan {engine.makespan_s:.0f}" if engine.makespan_s else f"stopped at {sim:.0f}"
    print(f"{label}: {end} simulated s, {calls} step calls for {engine.steps} simulated steps, "
          f"{wall:.2f} s wall, {cpu:.2f} s CPU")
    print(f"  speed: {sim / cpu:,.0f} x real time per CPU second ({sim / wall:,.0f} x wall)")
    accounted = sum(clock.seconds.values())
    clock.seconds["other (advance, metrics)"] = wall - accounted
    for stage, seconds in sorted(clock.seconds.items(), key=lambda kv: -kv[1]):
        print(f"    {stage:38s} {seconds:6.2f} s  {100 * seconds / wall:5.1f} %")
    return sim / cpu


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(parser)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--navigator", default=None,
                        help="a reaching policy (.zip) to time against the scripted navigator")
    parser.add_argument("--no-park", action="store_true",
                        help="idle crews need a decision every step (the paper's reading)")
    args = parser.parse_args(argv)
    scripted = report(f"built-in case, seed {args.seed}, scripted navigator",
                      *run(args.seed, None, not args.no_park))
    print(f"scripted navigator: {scripted:,.0f} x real time (target 20,000)")
    if args.navigator:
        policy = report(f"built-in case, seed {args.seed}, {args.navigator} (sampled)",
                        *run(args.seed, args.navigator, False))
        print(f"policy as low level: {policy:,.0f} x real time (target 8,000), "
              f"{policy / scripted:.2f} x the scripted navigator's speed in this run")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
