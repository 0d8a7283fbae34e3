"""``cmdp-ga``: search task priorities with a genetic algorithm (section 5.3's GA baseline).

    cmdp-ga [--config training/configs/ga.toml] [--set key=value ...] [--workers N]
            [--ray [ADDRESS]] [--out DIR] [--resume]

The episodes run in worker processes, or on Ray actors with ``--ray`` (a Ray started here)
or ``--ray ADDRESS`` (a cluster; docs/ray.md): the same search either way.

Writes into DIR: ``best.json`` (the best priority file so far: use it with
``cmdp-simulate --evaluator ga:DIR/best.json``), ``history.csv`` (best, mean and worst
fitness per generation), ``checkpoint.pkl`` (after every generation; ``--resume`` continues
from it, exactly as if never stopped) and ``config.json`` (settings, case, versions, command).
The settings are ``training.search.genetic.GAConfig``'s; a bad one exits with 2 naming it and
the fix.
"""

from __future__ import annotations

import sys
from pathlib import Path

import cmdp_pymunk
from training.cli import (
    SearchArgs,
    parse_search_args,
    workers_label,
    write_search_settings,
)
from training.config import RunConfig
from training.runs.backends import BackendError
from training.search.genetic import GAConfig, run_ga

DEFAULT_CONFIG = Path(__file__).parents[1] / "configs" / "ga.toml"


def parse_args(argv: list[str] | None = None) -> SearchArgs:
    return parse_search_args("cmdp-ga", __doc__, DEFAULT_CONFIG, Path("runs/ga"),
                             "best.json, history.csv and the checkpoint", argv)


class GARunConfig(GAConfig, RunConfig):
    """``training.search.genetic.GAConfig`` read like every run config
    (``training.config.RunConfig.load``:
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
    write_search_settings(args.out, config, case, args.workers, args.ray)
    print(f"cmdp-ga: case {case.case.name!r}, {len(case.tasks)} genes, population "
          f"{config.population}, {config.generations} generations, training seeds "
          f"{config.train_seeds}, " + workers_label(args.workers, args.ray))
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
