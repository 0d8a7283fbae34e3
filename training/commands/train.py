"""cmdp-train: train the stage-1 reaching policy or the stage-2 target-evaluation policy.

    cmdp-train stage1 [--config training/configs/stage1.toml] [--set key=value ...]
                      [--out runs/stage1] [--resume CHECKPOINT.zip] [--no-progress]
    cmdp-train stage2 [--config training/configs/stage2.toml] [--set key=value ...]
                      [--out runs/stage2] [--resume CHECKPOINT.zip] [--no-progress]
                      [--ray [ADDRESS]]

The settings are checked first (exit status 2 with one line for a bad one); the run is then
``training.stage1.train`` or ``training.stage2.train``. ``total_steps`` is rounded up to whole
PPO rollouts (n_steps x envs), which is what runs and what the progress bar counts to.
Ctrl-C: exit status 130 with one line saying what was saved and how to resume.

``stage2 --ray`` steps the floors on ``num_cpus`` Ray actors (a Ray started here; ``--ray
ADDRESS``: a cluster's) instead of worker processes, with the same decisions
(``training.ray_vec_env``; docs/ray.md); the learner stays in this process. Ray missing, an
address nobody answers at or workers without this package exit 2 with one line.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cmdp_pymunk
from training import stage1, stage2
from training.cli import add_ray_option
from training.scaffold import TrainingInterrupted

STAGES = {"stage1": (stage1, stage1.Stage1Config, "the shared target-reaching policy "
                     "(section 4.2)"),
          "stage2": (stage2, stage2.Stage2Config, "the target-evaluation policy "
                     "(section 3.6.1)")}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="cmdp-train", description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(parser)
    sub = parser.add_subparsers(dest="stage", required=True,
                                help="which policy to train (cmdp-train STAGE --help)")
    for stage, (_, _, what) in STAGES.items():
        p = sub.add_parser(
            stage, help=f"train {what}",
            description=f"cmdp-train {stage}: train {what}. Settings from --config, each "
                        f"overridable with --set (the settings: docs/training-{stage}.md); "
                        "writes checkpoints, progress.csv, TensorBoard logs and "
                        "final_model.zip into --out; Ctrl-C saves a checkpoint to --resume from.")
        p.add_argument("--config", type=Path, default=None,
                       help=f"TOML settings (default: training/configs/{stage}.toml)")
        p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                       help="override a config setting (repeatable); total_steps is "
                            "rounded up to whole PPO rollouts (n_steps x envs), what runs")
        p.add_argument("--out", type=Path, default=Path(f"runs/{stage}"),
                       help=f"run folder (default: runs/{stage})")
        p.add_argument("--resume", type=Path, default=None, help="a checkpoint .zip to resume")
        p.add_argument("--no-progress", action="store_true", help="show no progress bar")
        if stage == "stage2":  # stage 1's copies run in SuperSuit's own process pool
            add_ray_option(p)
    args = parser.parse_args(argv)
    argv = argv if argv is not None else sys.argv[1:]
    module, config_class, _ = STAGES[args.stage]
    return run_guarded(lambda: start(config_class, module.DEFAULT_CONFIG, module.train, args,
                                     argv))


def start(config_class, default_config: Path, train_run, args, argv) -> Path | int:
    """Settings checked, then ``train_run``: the final model's path, or 2 with one line for
    bad settings (``main`` runs this under its Ctrl-C guard)."""
    from training.runs.backends import BackendError

    ray = getattr(args, "ray", None)
    try:
        config = config_class.load(args.config or default_config, args.set)
        cmdp_pymunk.load_case(config.case)
        if args.resume is not None and not args.resume.is_file():
            raise ValueError(f"--resume {args.resume}: no such checkpoint")
        if ray is not None:  # before the run folder: Ray missing, an address nobody answers
            from training.runs.ray_backend import check_address, require_ray

            require_ray()
            if ray != "local":
                check_address(ray)
    except (cmdp_pymunk.CaseError, ValueError, TypeError) as err:
        print(f"cmdp-train: {err}", file=sys.stderr)
        return 2
    extra = {"ray": ray} if ray is not None else {}
    try:
        return train_run(config, args.out, args.resume, argv=argv,
                         progress_bar=not args.no_progress, **extra)
    except BackendError as err:  # Ray's actors could not start: before any training
        print(f"cmdp-train: {err}", file=sys.stderr)
        return 2


def run_guarded(start) -> int:
    """``cmdp-train``'s exit status for ``start()`` (the final model's path, or an exit
    status for bad settings) under ``sigint_guard``: 130 with one line on Ctrl-C."""
    from cmdp_pymunk.interrupt import sigint_guard

    try:
        with sigint_guard():  # a Ctrl-C inside pymunk's callbacks still stops training
            final = start()
    except TrainingInterrupted as err:
        print(f"\ncmdp-train: {err}", file=sys.stderr)
        return 130
    except KeyboardInterrupt:
        print("\ncmdp-train: interrupted while starting, before any training: nothing to "
              "resume; start again with the same command", file=sys.stderr)
        return 130
    if isinstance(final, int):
        return final
    print(f"cmdp-train: final model {final}")
    return 0


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
