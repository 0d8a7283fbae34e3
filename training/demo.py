"""A demo run: one episode on a case, priority heuristic and scripted navigator, and a frame.

``make demo`` runs ``python -m training.demo --out out/demo``. Target values come from the
priority heuristic (Eq. 9, ``agents.priority``); the scripted navigator (``agents.navigator``)
drives every crew that needs a movement decision.

Outputs in ``--out``: ``frame.png``, the last state of the site.
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import cmdp_pymunk
from agents.navigator import Navigator
from agents.priority import PriorityEvaluator
from cmdp_pymunk.events import write_atomic


@dataclass(frozen=True)
class DemoArgs:
    """The demo's arguments.

    out: folder for the outputs (created). seed: the episode's seed. max_time_s: simulated
    seconds after which the episode is cut short. case: a case file (TOML), or None for the
    built-in precast floor. progress_every_s: wall-clock seconds between progress lines.
    """

    out: Path
    seed: int = 0
    max_time_s: float = 4000.0
    case: Path | None = None
    progress_every_s: float = 2.0


def parse_args(argv: list[str] | None = None) -> DemoArgs:
    parser = argparse.ArgumentParser(prog="cmdp-demo", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/demo"),
                        help="output folder (default: out/demo)")
    parser.add_argument("--seed", type=int, default=0, help="episode seed (default: 0)")
    parser.add_argument("--max-time-s", type=float, default=4000.0,
                        help="stop after this many simulated seconds (default: 4000)")
    parser.add_argument("--case", type=Path, default=None,
                        help="case file (TOML); default: the built-in precast floor")
    ns = parser.parse_args(argv)
    if ns.max_time_s <= 0:
        parser.error(f"--max-time-s must be positive, not {ns.max_time_s}")
    return DemoArgs(out=ns.out, seed=ns.seed, max_time_s=ns.max_time_s, case=ns.case)


def run_episode(env, seed: int, progress_every_s: float = 2.0,
                report: Callable[[str], None] = print) -> None:
    """Reset the env and step it with the scripted navigator until the episode ends.

    The env's own ``max_time_s`` cuts the episode short; ``report`` gets a progress line
    (simulated time, tasks ended) every ``progress_every_s`` seconds of wall time.
    """
    env.reset(seed=seed)
    site = env.site
    navigator = Navigator(env)
    next_report = time.monotonic() + progress_every_s
    while env.agents:
        env.step(navigator.actions(env))
        if time.monotonic() >= next_report:
            next_report += progress_every_s
            report(f"  t = {site.time_s:7.0f} s   tasks ended {site.tasks_ended}/"
                   f"{len(site.tasks)}")


def save_png(path: Path, frame) -> None:
    """Encode the frame as PNG and write it atomically (temp file, then os.replace)."""
    import imageio.v3 as iio

    buf = io.BytesIO()
    iio.imwrite(buf, frame, extension=".png")
    write_atomic(path, buf.getvalue())


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        case = cmdp_pymunk.load_case(args.case)
    except cmdp_pymunk.CaseError as err:
        print(f"cmdp-demo: {err}", file=sys.stderr)
        return 2
    env = cmdp_pymunk.parallel_env(case=case, seed=args.seed, render_mode="rgb_array",
                                   max_time_s=args.max_time_s, evaluator=PriorityEvaluator())
    print(f"cmdp-demo: case {case.case.name!r}, {len(case.crews)} crews, {len(case.tasks)} "
          f"tasks, seed {args.seed}, up to {args.max_time_s:g} simulated s")
    start = time.monotonic()
    run_episode(env, args.seed, args.progress_every_s)
    site = env.site
    frame_path = args.out / "frame.png"
    save_png(frame_path, env.render())
    ended = "every task ended" if site.done else "cut short"
    print(f"cmdp-demo: {ended} at t = {site.time_s:.0f} s: {site.tasks_ended}/"
          f"{len(site.tasks)} tasks ended ({time.monotonic() - start:.1f} s wall)")
    print(f"cmdp-demo: wrote {frame_path}")
    return 0


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
