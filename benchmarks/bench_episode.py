"""One whole episode on the built-in case (priority heuristic, scripted navigator, no GIF):
simulated seconds per wall second, and the split between physics, rays, decisions and
navigation, measured in one run.

    python benchmarks/bench_episode.py [--seed 0]

Target: 10,000 times real time or better on one core.
"""

from __future__ import annotations

import argparse
import time

import cmdp_pymunk
from agents.navigator import Navigator
from agents.priority import PriorityEvaluator
from cmdp_pymunk.timing import StageClock


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-park", action="store_true",
                        help="idle crews need a decision every step (the paper's reading)")
    args = parser.parse_args(argv)
    env = cmdp_pymunk.parallel_env(seed=args.seed, evaluator=PriorityEvaluator(),
                                   park_idle=not args.no_park)
    clock = StageClock()
    env.clock = clock
    observations, _ = env.reset(seed=args.seed)
    navigator = Navigator(env)
    calls = 0
    start = time.perf_counter()
    while env.agents:
        t0 = time.perf_counter()
        actions = navigator.actions(env, observations)
        clock.seconds["navigation"] += time.perf_counter() - t0
        observations, *_ = env.step(actions)
        calls += 1
    wall = time.perf_counter() - start
    sim = env.site.time_s
    print(f"built-in case, seed {args.seed}: makespan {env.makespan_s:.0f} simulated s, "
          f"{calls} step calls for {env.steps} simulated steps, {wall:.2f} s wall")
    print(f"speed: {sim / wall:,.0f} x real time (target 10,000 or better)")
    accounted = sum(clock.seconds.values())
    clock.seconds["other (env.step bookkeeping, infos)"] = wall - accounted
    for stage, seconds in sorted(clock.seconds.items(), key=lambda kv: -kv[1]):
        print(f"  {stage:38s} {seconds:6.2f} s  {100 * seconds / wall:5.1f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
