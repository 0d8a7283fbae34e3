"""``cmdp-ga``: search task priorities with a genetic algorithm (section 5.3's GA baseline).

    cmdp-ga [--config training/configs/ga.toml] [--set key=value ...] [--workers N]
            [--ray [ADDRESS]] [--out DIR] [--resume]

The episodes run in worker processes, or on Ray actors with ``--ray`` (a Ray started here)
or ``--ray ADDRESS`` (a cluster; docs/ray.md): the same search either way.

Writes into DIR: ``best.json`` (the best priority file so far: use it with
``cmdp-simulate --evaluator ga:DIR/best.json``), ``history.csv`` (best, mean and worst
fitness per generation), ``checkpoint.pkl`` (after every generation; ``--resume`` continues
from it, exactly as if never stopped) and ``config.json`` (settings, case, versions, command).
The settings are ``agents.ga.GAConfig``'s; a bad one exits with 2 naming it and the fix.
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

import cmdp_pymunk
from agents.episodes import BackendError, default_workers
from agents.ga import GAConfig, run_ga
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.rollout import versions
from training.cli import OneLineParser, add_ray_option, positive_int
from training.config import RunConfig

DEFAULT_CONFIG = Path(__file__).with_name("configs") / "ga.toml"


@dataclass(frozen=True)
class GAArgs:
    config: Path
    overrides: tuple[str, ...]
    workers: int | None
    out: Path
    resume: bool
    progress: bool
    ray: str | None = None


def parse_args(argv: list[str] | None = None) -> GAArgs:
    p = OneLineParser(prog="cmdp-ga", description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--config", type=Path, default=DEFAULT_CONFIG)
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a setting of the config")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="worker processes for the episodes, or Ray actors with --ray "
                        "(default: every core; with --ray ADDRESS, every CPU of the cluster)")
    add_ray_option(p)
    p.add_argument("--out", type=Path, default=Path("runs/ga"))
    p.add_argument("--resume", action="store_true",
                   help="continue from DIR/checkpoint.pkl")
    p.add_argument("--no-progress", action="store_true")
    a = p.parse_args(argv)
    return GAArgs(a.config, tuple(a.set), a.workers, a.out, a.resume, not a.no_progress,
                  a.ray)


class GARunConfig(GAConfig, RunConfig):
    """``agents.ga.GAConfig`` read like every run config (``training.config.RunConfig.load``:
    the TOML file, then ``--set`` overrides, every bad setting named with its fix)."""


def load_config(path: Path, overrides: tuple[str, ...]) -> GAConfig:
    """The config file with ``--set`` overrides, validated (ValueError naming each problem)."""
    return GARunConfig.load(path, list(overrides))


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        config = load_config(args.config, args.overrides)
        case = cmdp_pymunk.load_case(config.case)
    except ValueError as err:  # CaseError is a ValueError
        print(f"cmdp-ga: {err}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    write_atomic(args.out / "config.json", json.dumps(
        {"config": config.model_dump(), "case": case.model_dump(mode="json"),
         "workers": args.workers, "ray": args.ray, "command": sys.argv, "versions": versions()},
        indent=2) + "\n")
    print(f"cmdp-ga: case {case.case.name!r}, {len(case.tasks)} genes, population "
          f"{config.population}, {config.generations} generations, training seeds "
          f"{config.train_seeds}, " + (f"Ray ({args.ray})" if args.ray else
                                        f"{args.workers or default_workers()} worker(s)"))
    try:
        state = run_ga(case, config, args.out, args.workers, args.resume, args.progress,
                       args.ray)
    except (ValueError, BackendError) as err:
        print(f"cmdp-ga: {err}", file=sys.stderr)
        return 2
    for row in state.log:
        print(f"cmdp-ga: generation {row['generation']}: best {row['best']:.0f}, mean "
              f"{row['mean']:.0f} ({row['evaluations']} episodes so far)")
    print(f"cmdp-ga: best fitness {state.best[1]:.0f} -> {args.out / 'best.json'}")
    return 0


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
