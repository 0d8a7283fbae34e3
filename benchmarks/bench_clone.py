"""Branching a floor: ``Engine.clone`` against replaying the floor from reset to the same
second, measured in one run (the lookahead needs one of the two at every decision).

    python benchmarks/bench_clone.py [--seed 0] [--at 4000,16000,28000] [--repeat 5]

For each moment: the median wall time of ``clone`` (with the env and the scripted navigator,
and with ``keep_log=False`` as the lookahead uses it), of a replay from reset to that second,
and their ratio. Both give the same floor (tests/test_branching.py).
"""

from __future__ import annotations

import argparse
import statistics
import time

import cmdp_pymunk
from agents.navigator import Navigator


def floor(seed: int):
    env = cmdp_pymunk.parallel_env(seed=seed, evaluator="priority", park_idle=True, blind=True)
    navigator = Navigator(env)
    env.reset(seed=seed)
    navigator.reset(seed)
    return env, navigator


def run_to(env, navigator, t: float) -> None:
    while env.agents and env.engine.site.time_s < t:
        env.step(navigator.actions(env, None))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    cmdp_pymunk.add_version_flag(parser)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--at", default="4000,16000,28000", help="seconds of the floor")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    print(f"{'t (s)':>7} {'clone (ms)':>11} {'clone, no log':>14} {'replay (ms)':>12} "
          f"{'replay / clone':>15}")
    for t in (float(x) for x in args.at.split(",")):
        env, navigator = floor(args.seed)
        run_to(env, navigator, t)
        clones, lean, replays = [], [], []
        for _ in range(args.repeat):
            start = time.perf_counter()
            env.engine.clone(companions=(env, navigator))
            clones.append(time.perf_counter() - start)
            start = time.perf_counter()
            env.engine.clone(companions=(env, navigator), keep_log=False)
            lean.append(time.perf_counter() - start)
            start = time.perf_counter()
            replay, replay_nav = floor(args.seed)
            run_to(replay, replay_nav, t)
            replays.append(time.perf_counter() - start)
        c, n, r = (statistics.median(x) * 1000 for x in (clones, lean, replays))
        print(f"{t:7.0f} {c:11.1f} {n:14.1f} {r:12.1f} {r / n:15.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
