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
from cmdp_pymunk.engine import Engine


def floor(seed: int):
    engine = Engine(cmdp_pymunk.load_case(None), evaluator="priority", park_idle=True)
    navigator = Navigator()
    engine.reset(seed)
    navigator.reset(seed)
    return engine, navigator


def run_to(engine, navigator, t: float) -> None:
    while engine.site.time_s < t:
        run = engine.advance(navigator.actions(engine), until=engine.decision_due)
        if run.terminated or run.truncated:
            return


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
        engine, navigator = floor(args.seed)
        run_to(engine, navigator, t)
        clones, lean, replays = [], [], []
        for _ in range(args.repeat):
            start = time.perf_counter()
            engine.clone()  # the navigator's plans come along (engine.memory)
            clones.append(time.perf_counter() - start)
            start = time.perf_counter()
            engine.clone(keep_log=False)
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
