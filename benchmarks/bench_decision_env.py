"""Decisions per second of the stage-2 decision env on both floors, measured in one run.

``cmdp/TargetEvaluation-v1`` (the pymunk floor, the scripted navigator driving the crews
between decisions) against ``cmdp/TargetEvaluationEvent-v1`` (the event floor, which jumps
from event to event), both made by ``gymnasium.make`` on the same case, on one core, under
random actions (one seeded generator per env, so both see the same action sequence). A
decision is one ``env.step``; resets are counted in the time, as an RL user pays them. Each
env first plays one untimed episode (the event floor's walk planner fills its shortest-path
fields in the first one: its time is printed apart), then rounds alternate the two envs on
the same seeds so that both see the same machine load. Issue 30's target for the event
floor: thousands of decisions a second.

    python benchmarks/bench_decision_env.py [--case PATH] [--rounds 3] [--episodes 2]
        [--profile 20]   # then cProfile the event env over 20 episodes, top functions
"""

from __future__ import annotations

import argparse
import os
import time

import gymnasium
import numpy as np

import cmdp_pymunk

IDS = ("cmdp/TargetEvaluation-v1", "cmdp/TargetEvaluationEvent-v1")


def play(env, seeds, rng) -> tuple[int, float]:
    """Decisions and seconds for one episode per seed under uniform random actions."""
    decisions = 0
    t0 = time.perf_counter()
    for seed in seeds:
        env.reset(seed=seed)
        while True:
            decisions += 1
            *_, terminated, truncated, _ = env.step(rng.uniform(-1.0, 1.0, 2).astype(np.float32))
            if terminated or truncated:
                break
    return decisions, time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(parser)
    parser.add_argument("--case", default=None, help="a case file (default: the built-in case)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--episodes", type=int, default=2, help="episodes per env per round")
    parser.add_argument("--profile", type=int, default=0,
                        help="then cProfile this many event-floor episodes")
    args = parser.parse_args(argv)
    if hasattr(os, "sched_setaffinity"):  # one core, as a vector env's worker would have
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    kwargs = {"case": args.case} if args.case else {}
    envs = {env_id: gymnasium.make(env_id, **kwargs) for env_id in IDS}
    rngs = {env_id: np.random.default_rng(0) for env_id in IDS}
    totals = {env_id: [0, 0.0] for env_id in IDS}
    for env_id, env in envs.items():  # untimed: caches, the walk planner's fields
        n, seconds = play(env, [10_000], rngs[env_id])
        print(f"  {env_id}: first episode {n} decisions in {seconds:.2f} s (warm-up, untimed)")
    for r in range(args.rounds):
        seeds = range(r * args.episodes, (r + 1) * args.episodes)
        for env_id, env in envs.items():
            n, seconds = play(env, seeds, rngs[env_id])
            totals[env_id][0] += n
            totals[env_id][1] += seconds
    rates = {}
    for env_id, (n, seconds) in totals.items():
        rates[env_id] = n / seconds
        episodes = args.rounds * args.episodes
        print(f"{env_id}: {rates[env_id]:,.0f} decisions/s ({n} decisions, {episodes} "
              f"episodes, {seconds:.2f} s, {1000 * seconds / episodes:.0f} ms an episode)")
    pymunk_id, event_id = IDS
    print(f"event / pymunk: {rates[event_id] / rates[pymunk_id]:.1f} x")
    if args.profile:
        import cProfile
        import pstats

        profiler = cProfile.Profile()
        profiler.enable()
        play(envs[event_id], range(100, 100 + args.profile), rngs[event_id])
        profiler.disable()
        pstats.Stats(profiler).sort_stats("cumulative").print_stats(30)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
