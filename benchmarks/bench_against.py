"""This checkout's event floor and stage-2 event env against another checkout's, in one process.

    git archive COMMIT | tar -x -C /tmp/before          # the code to compare against
    python benchmarks/bench_against.py --base /tmp/before [--rounds 3] [--seeds 0-9]

On a machine shared with other jobs a timing moves by tens of percent from one minute to the
next; two runs in turn compare the load as much as the code. Here both versions run in one
process, floor by floor in alternating order on the same seeds, so that both meet the same load:
the other checkout's ``cmdp_pymunk`` is copied under another package name (it imports itself
only relatively) and imported beside this one. Prints CPU ms a floor (built-in case, priority
evaluator, the case's calibration, the CLI's stall guard) and decisions a second of the
stage-2 event env (``make_decision_env(fidelity="event")``, random actions, one generator
per env), each with the ratio, and checks that both give the same makespans and decisions
(``event_floor_reference.py`` checks every result).
"""

from __future__ import annotations

import argparse
import importlib
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import cmdp_pymunk
from training.cli import seed_list


def load_base(checkout: Path, into: Path):
    """The other checkout's ``cmdp_pymunk``, imported as ``cmdp_base``."""
    source = checkout / "cmdp_pymunk"
    if not (source / "engine.py").is_file():
        raise SystemExit(f"--base {checkout}: no cmdp_pymunk/engine.py there; fix: give the root "
                         "of a checkout (e.g. git archive COMMIT | tar -x -C DIR)")
    shutil.copytree(source, into / "cmdp_base")
    sys.path.insert(0, str(into))
    with warnings.catch_warnings():  # it registers the same env ids again
        warnings.simplefilter("ignore")
        return importlib.import_module("cmdp_base")


def floors(pkg):
    """An event floor of the built-in case on ``pkg``'s code, its first floor run (paths)."""
    events = importlib.import_module(pkg.__name__ + ".eventfloor")
    case = pkg.load_case(None)
    floor = events.EventFloor(case, evaluator="priority", stall_s=3600.0,
                              calibration=events.calibration_for(case, None))
    floor.reset(0)
    floor.run()
    return floor


def play(env, rng, seed) -> int:
    """Decisions of one episode under uniform random actions."""
    env.reset(seed=seed)
    n = 0
    while True:
        n += 1
        *_, terminated, truncated, _ = env.step(rng.uniform(-1.0, 1.0, 2).astype(np.float32))
        if terminated or truncated:
            return n


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--base", type=Path, required=True, help="root of the other checkout")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--seeds", type=seed_list, default=list(range(10)))
    p.add_argument("--episodes", type=int, default=6, help="env episodes per round")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        base = load_base(args.base, Path(tmp))
        pkgs = {"base": base, "this": cmdp_pymunk}
        made = {k: floors(pkg) for k, pkg in pkgs.items()}
        cpu = {k: 0.0 for k in pkgs}
        makespans = {k: [] for k in pkgs}
        for r in range(args.rounds):
            for s, seed in enumerate(args.seeds):
                for k in (("base", "this") if (r + s) % 2 == 0 else ("this", "base")):
                    t = time.process_time()
                    made[k].reset(seed)
                    made[k].run()
                    cpu[k] += time.process_time() - t
                    makespans[k].append(made[k].makespan_s)
        n = args.rounds * len(args.seeds)
        ms = {k: 1000 * v / n for k, v in cpu.items()}
        print(f"event floor, {n} floors each: base {ms['base']:.1f} CPU ms a floor, this "
              f"{ms['this']:.1f}: {ms['base'] / ms['this']:.2f} x faster; makespans "
              f"{'identical' if makespans['base'] == makespans['this'] else 'DIFFER'}")
        envs = {k: importlib.import_module(pkg.__name__ + ".adapters.decision_loop")
                .make_decision_env(fidelity="event") for k, pkg in pkgs.items()}
        rngs = {k: np.random.default_rng(0) for k in pkgs}
        for k in pkgs:  # untimed: the walk planner's fields of a first episode
            play(envs[k], rngs[k], 10_000)
        decisions = {k: [0, 0.0] for k in pkgs}
        for r in range(args.rounds):
            for e in range(args.episodes):
                for k in (("base", "this") if (r + e) % 2 == 0 else ("this", "base")):
                    t = time.process_time()
                    decisions[k][0] += play(envs[k], rngs[k], r * args.episodes + e)
                    decisions[k][1] += time.process_time() - t
        rate = {k: d / t for k, (d, t) in decisions.items()}
        same = decisions["base"][0] == decisions["this"][0]
        print(f"stage-2 event env, {args.rounds * args.episodes} episodes each: base "
              f"{rate['base']:,.0f} decisions/s, this {rate['this']:,.0f}: "
              f"{rate['this'] / rate['base']:.2f} x; decisions "
              f"{'identical' if same else 'DIFFER'} ({decisions['this'][0]})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
