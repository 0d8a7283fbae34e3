"""Where a scripted floor's CPU time goes: quiet seconds (no crew moves, no decision due: what
an event jump would skip), moving seconds, the navigator and the rest, in one run.

    python benchmarks/bench_quiet.py [--seed 0]

Prints the count and CPU seconds of each part and the largest speed-up an event jump over
the quiet seconds could give (all their time saved), so the jump is weighed before it is built.
"""

from __future__ import annotations

import argparse
import time

import cmdp_pymunk
from agents.navigator import Navigator
from cmdp_pymunk.engine import Engine


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    cmdp_pymunk.add_version_flag(parser)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    acc = {"quiet": [0, 0.0], "moving": [0, 0.0]}
    step = Engine.step

    def timed_step(self, actions):
        quiet = self.quiet()  # as Engine.step decides
        start = time.process_time()
        out = step(self, actions)
        part = acc["quiet" if quiet else "moving"]
        part[0] += 1
        part[1] += time.process_time() - start
        return out

    Engine.step = timed_step
    try:
        engine = Engine(cmdp_pymunk.load_case(None), evaluator="priority", park_idle=True)
        navigator = Navigator()
        engine.reset(args.seed)
        navigator.reset(args.seed)
        start, nav_s = time.process_time(), 0.0
        while True:
            t = time.process_time()
            actions = navigator.actions(engine)
            nav_s += time.process_time() - t
            run = engine.advance(actions, until=engine.decision_due)
            if run.terminated or run.truncated:
                break
        total = time.process_time() - start
    finally:
        Engine.step = step
    (nq, quiet_s), (nm, moving_s) = acc["quiet"], acc["moving"]
    print(f"seed {args.seed}: makespan {engine.makespan_s:.0f} s, {total:.2f} CPU s in all")
    print(f"  quiet seconds:  {nq:6d} ({nq / (nq + nm):.0%} of seconds), {quiet_s:.2f} CPU s "
          f"({quiet_s / total:.0%})")
    print(f"  moving seconds: {nm:6d}, {moving_s:.2f} CPU s ({moving_s / total:.0%})")
    print(f"  navigator: {nav_s:.2f} CPU s ({nav_s / total:.0%}); the env and the rest: "
          f"{total - quiet_s - moving_s - nav_s:.2f} CPU s")
    print(f"  an event jump over every quiet second: at most {total / (total - quiet_s):.2f} x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
