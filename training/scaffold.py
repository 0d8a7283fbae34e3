"""The PPO run both training stages share (``cmdp-train stage1|stage2``).

A stage brings its settings (a ``PPOSettings`` with its own values), its vector env, its
policy, its warm start, its metrics and its evaluation; ``train_ppo`` runs them in this order:

    torch threads -> run folder: config{-N}.json, case.json -> seeds
    -> the vector env (SIGINT blocked while it forks its workers)
    -> PPO: new (``new_ppo``, then the warm start) or resumed from a checkpoint
    -> learn: the stage's metrics; evaluation on fixed seeds (best_model.zip, best.json) and
       checkpoints every so many steps (``periodic_callback``)
    -> final_model.zip -> training_curve.png from every progress*.csv of the folder

A resumed run adds ``config-N.json`` and ``progress-N.csv`` and never overwrites the first
part's history. Ctrl-C during PPO saves ``checkpoints/interrupted.zip`` and raises
``TrainingInterrupted`` saying how to resume; during the warm start nothing can be saved yet.
SB3 and torch are imported when a run starts, so ``cmdp-train --version`` stays quick.
"""

from __future__ import annotations

import contextlib
import copy
import functools
import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from pydantic import field_validator, model_validator

from cmdp_pymunk.cases.load import Case
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.report import versions

from .config import Count, CountOrZero, Rate, RateOrZero, RunConfig, Sizes

say = functools.partial(print, flush=True)  # a run's log lines, at once even through a pipe


class PPOSettings(RunConfig):
    """The settings every PPO run has. A stage adds its own and gives in ``DEFAULTS`` its
    values of those without a default here ("the stage's"); its TOML file and ``--set``
    override both. ``num_cpus`` <= ``n_envs`` is checked by ``RunConfig``."""

    DEFAULTS: ClassVar[dict[str, Any]] = {}

    case: str | None = None  # case file; None: the built-in case
    seed: CountOrZero = 0
    # the stage's, in its unit: agent-steps (stage 1) or decisions (stage 2); rounded up to
    # whole rollouts (n_steps x envs), which is what PPO runs
    total_steps: Count
    n_envs: Count  # the stage's: env copies
    num_cpus: Count  # the stage's: processes stepping the copies (1: all in this process)
    torch_threads: Count = 1
    # PPO (Eq. 8 is SB3's ppo.py); n_steps: samples per env copy before each update
    learning_rate: Rate
    n_steps: Count = 256
    batch_size: Count
    n_epochs: Count
    gamma: RateOrZero
    gae_lambda: RateOrZero = 0.95
    clip_range: RateOrZero
    ent_coef: RateOrZero
    vf_coef: RateOrZero = 0.5
    net_arch: Sizes = [128, 128]
    # warm start: behaviour cloning of the stage's teacher
    bc_epochs: CountOrZero
    bc_batch_size: Count
    bc_learning_rate: Rate = 1e-3
    # evaluation on fixed seeds and checkpoints, every so many steps of the stage's unit
    eval_every_steps: Count
    eval_seeds: Sizes
    checkpoint_every_steps: Count
    # Weights & Biases (opt-in, docs/training-stage1.md): a project name logs the run there
    # through SB3's WandbCallback; needs `pip install wandb` (not a dependency)
    wandb_project: str | None = None

    @field_validator("wandb_project")
    @classmethod
    def _wandb_installed(cls, project: str | None) -> str | None:
        import importlib.util

        if project and importlib.util.find_spec("wandb") is None:
            raise ValueError("asks for Weights & Biases, but wandb is not installed; fix: "
                             "pip install wandb (then wandb login), or drop wandb_project")
        return project

    @model_validator(mode="before")
    @classmethod
    def _stage_defaults(cls, data: Any) -> Any:
        return {**copy.deepcopy(cls.DEFAULTS), **data} if isinstance(data, dict) else data


@dataclass
class Run:
    """One training run: its settings and case, its folder, what ``total_steps`` counts
    (``unit``), and how it was started (``resume``: a checkpoint; ``argv``: the command)."""

    config: PPOSettings
    case: Case
    folder: Path
    unit: str
    resume: Path | None = None
    argv: list[str] | None = None
    progress_bar: bool = True
    log: Callable[[str], None] = say
    suffix: str = field(default="", init=False)  # "-N" for the N-th resumed part

    def prologue(self) -> None:
        """Torch's threads, the run folder's ``config{suffix}.json`` (settings, command,
        checkpoint resumed from, versions) and ``case.json``, and every seed."""
        import torch
        from stable_baselines3.common.utils import set_random_seed

        torch.set_num_threads(self.config.torch_threads)
        torch.distributions.Distribution.set_default_validate_args(False)
        self.folder.mkdir(parents=True, exist_ok=True)
        if self.resume is not None:  # a resumed run adds files, never overwrites the history
            self.suffix = f"-{1 + sum(1 for _ in self.folder.glob('progress-*.csv'))}"
        write_atomic(self.folder / f"config{self.suffix}.json", json.dumps(
            {"config": self.config.model_dump(), "command": self.argv,
             "resumed_from": str(self.resume) if self.resume else None,
             "versions": versions()}, indent=2))
        write_atomic(self.folder / "case.json",
                     json.dumps(self.case.model_dump(mode="json"), indent=2))
        set_random_seed(self.config.seed)


@dataclass
class Evaluation:
    """A stage's evaluation on fixed seeds: ``play(model)`` gives a dict of numbers (logged as
    ``eval/<key>``), ``describe(result)`` its log line, ``score(result)`` its rank (higher
    is better; None: it may not be the best model, e.g. a floor unfinished). ``at_start``:
    evaluate before the first update too, where the warm start stands."""

    play: Callable[[Any], dict]
    describe: Callable[[dict], str]
    score: Callable[[dict], float | None]
    at_start: bool = False


def steps_done(checkpoint: Path | None) -> int:
    """The number of steps a checkpoint had trained (0 for a fresh run), read without
    building its model."""
    if checkpoint is None:
        return 0
    from stable_baselines3.common.save_util import load_from_zip_file

    return load_from_zip_file(str(checkpoint), device="cpu")[0]["num_timesteps"]


def new_ppo(config: PPOSettings, policy, venv, policy_kwargs: dict, algorithm=None, **extra):
    """SB3's PPO (or ``algorithm``, a PPO of sb3-contrib's such as MaskablePPO) with the
    run's settings (``extra``: more of PPO's arguments)."""
    from stable_baselines3 import PPO

    return (algorithm or PPO)(
        policy, venv, learning_rate=config.learning_rate, n_steps=config.n_steps,
        batch_size=config.batch_size, n_epochs=config.n_epochs, gamma=config.gamma,
        gae_lambda=config.gae_lambda, clip_range=config.clip_range, ent_coef=config.ent_coef,
        vf_coef=config.vf_coef, policy_kwargs=policy_kwargs, device="cpu", verbose=0, **extra)


def train_ppo(run: Run, make_venv: Callable[[], Any], new_model: Callable[[Any], Any],
              warm_start: Callable[[Any], None] | None, skip_warm_start: str,
              metrics, evaluation: Evaluation, draw_curve: Callable[[list, Path], Any],
              env_space_on_resume: bool = False, algorithm=None) -> Path:
    """Train (or resume) ``run`` in the order of the module doc; returns the final model's
    path. ``new_model(venv)`` builds a fresh PPO (``new_ppo``); ``warm_start(model)`` runs
    before PPO on a fresh model, and ``skip_warm_start`` (``key=value``) names the setting
    that turns it off. ``metrics``: the stage's SB3 callback. ``env_space_on_resume``: load
    a checkpoint with the env's observation space (one saved with an unbounded space of the
    same shape, before the bounds were known). ``algorithm``: the class resumed (default
    SB3's PPO). Ctrl-C raises ``TrainingInterrupted``."""
    from stable_baselines3 import PPO

    run.prologue()
    venv = without_sigint(make_venv)
    try:
        if run.resume is not None:
            objects = {"observation_space": venv.observation_space} if env_space_on_resume \
                else None
            model = (algorithm or PPO).load(str(run.resume), env=venv, device="cpu",
                                            custom_objects=objects)
            run.log(f"resumed from {run.resume} at {model.num_timesteps:,} {run.unit}")
        else:
            model = new_model(venv)
            if warm_start is not None:
                try:
                    warm_start(model)
                except KeyboardInterrupt:
                    raise TrainingInterrupted(
                        "interrupted during behaviour cloning (the warm start before PPO): "
                        "nothing could be saved yet, there is no model before it ends; "
                        f"{run.folder} holds only config{run.suffix}.json and case.json; "
                        f"start again with the same command (or --set {skip_warm_start} to "
                        "skip cloning)") from None
        with wandb_run(run) as extra:
            final = learn(model, run, [metrics, periodic_callback(run, evaluation), *extra])
    finally:
        venv.close()
    try:
        draw_curve(sorted(run.folder.glob("progress*.csv")), run.folder / "training_curve.png")
    except (FileNotFoundError, ValueError) as err:
        run.log(f"no training curve: {err}")
    return final


def vec_env(env_fns: list[Callable[[], Any]], num_cpus: int, vectorize=None,
            ray: str | None = None):
    """An SB3 vector env of ``len(env_fns)`` env copies stepped by ``num_cpus`` processes:
    all in this process for 1 (``vectorize(env_fns)``; default ``DummyVecEnv`` of Gymnasium
    envs), else that many worker processes, each stepping its share of the copies in one
    ``vectorize`` (``vec_env.ProcessGroupsVecEnv``). ``ray``: ``num_cpus`` Ray actors instead
    of processes ("local": a Ray started here; else a cluster's address;
    ``ray_vec_env.RayGroupsVecEnv``). Copy k is seeded ``seed + k`` by ``venv.seed(seed)``
    every way, so neither ``num_cpus`` nor Ray changes a result."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    vectorize = vectorize or DummyVecEnv
    if ray is not None:
        from .ray_vec_env import RayGroupsVecEnv

        return RayGroupsVecEnv(env_fns, num_cpus, ray, vectorize=vectorize)
    if num_cpus == 1:
        return vectorize(env_fns)
    from .vec_env import ProcessGroupsVecEnv

    return ProcessGroupsVecEnv(env_fns, num_cpus, vectorize=vectorize)


# -- evaluation and checkpoints ----------------------------------------------------------------

def next_multiple(t: int, every: int) -> int:
    """The first multiple of ``every`` after ``t``."""
    return t - t % every + every


def periodic_callback(run: Run, evaluation: Evaluation):
    """An SB3 callback: a checkpoint every ``checkpoint_every_steps`` and an evaluation every
    ``eval_every_steps``, keeping the best-scoring model (``best_model.zip``, ``best.json``:
    step, score and the evaluation; a resumed run goes on from its best)."""
    from stable_baselines3.common.callbacks import BaseCallback

    config, folder = run.config, run.folder

    class Periodic(BaseCallback):
        def _init_callback(self) -> None:
            done = self.model.num_timesteps
            self.next_eval = next_multiple(done, config.eval_every_steps)
            self.next_ckpt = next_multiple(done, config.checkpoint_every_steps)
            best_file = folder / "best.json"
            self.best = evaluation.score(json.loads(best_file.read_text())) \
                if best_file.exists() else None

        def _on_training_start(self) -> None:
            if evaluation.at_start and self.model.num_timesteps == 0:
                self._evaluate()

        def _on_step(self) -> bool:
            t = self.model.num_timesteps
            if t >= self.next_ckpt:
                self.next_ckpt = next_multiple(t, config.checkpoint_every_steps)
                save_model(self.model, folder / "checkpoints" / f"step_{t}.zip")
            if t >= self.next_eval:
                self._evaluate()
            return True

        def _evaluate(self) -> None:
            t = self.model.num_timesteps
            self.next_eval = next_multiple(t, config.eval_every_steps)
            t0 = time.perf_counter()
            result = evaluation.play(self.model)
            for k, v in result.items():
                self.logger.record(f"eval/{k}", v)
            if t == 0:  # before any update: a row of its own in progress.csv
                self.logger.record("time/total_timesteps", 0)
                self.logger.dump(0)
            run.log(f"\nevaluation at {t:,} {run.unit}: {evaluation.describe(result)} "
                    f"({time.perf_counter() - t0:.0f} s)")
            score = evaluation.score(result)
            if score is not None and (self.best is None or score > self.best):
                self.best = score
                save_model(self.model, folder / "best_model.zip")
                write_atomic(folder / "best.json", json.dumps(
                    {"step": t, "score": score, **result}, indent=2))

    return Periodic()


# -- PPO, Ctrl-C --------------------------------------------------------------------------------

def save_model(model, path: Path) -> None:
    """Saved to a temporary name, then renamed: a crash never leaves half a checkpoint."""
    import os

    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp.zip")
    try:
        model.save(str(tmp))
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


class TrainingInterrupted(KeyboardInterrupt):
    """Ctrl-C during training; its message says what was under way, what was saved and how
    to resume (``cmdp-train`` prints it as its one line)."""


def without_sigint(make):
    """``make()`` (a vector env) with SIGINT blocked, so that worker processes forked there
    never receive Ctrl-C: only this process does, and it stops them in order (a worker's own
    KeyboardInterrupt would come back through the pipe as a printed traceback)."""
    import signal

    blocked = hasattr(signal, "pthread_sigmask")
    if blocked:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        return make()
    finally:
        if blocked:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


@contextlib.contextmanager
def wandb_run(run: Run):
    """Weights & Biases, opt-in: with ``wandb_project`` set, a wandb run (the settings as its
    config, SB3's TensorBoard scalars synced, files under the run folder) and SB3's
    ``WandbCallback`` to add to ``learn``; else nothing. ``PPOSettings`` already refused the
    setting when wandb is not installed."""
    project = getattr(run.config, "wandb_project", None)
    if not project:
        yield []
        return
    import wandb
    from wandb.integration.sb3 import WandbCallback

    session = wandb.init(project=project, name=run.folder.name, dir=str(run.folder),
                         config=run.config.model_dump(mode="json"), sync_tensorboard=True)
    run.log(f"Weights & Biases: logging to project {project!r} ({session.url})")
    try:
        yield [WandbCallback(verbose=0)]
    finally:
        session.finish()


def whole_rollouts(steps: int, rollout: int) -> int:
    """``steps`` rounded up to whole rollouts of ``rollout`` steps: what PPO runs when asked
    for ``steps`` (``learn`` collects ``n_steps`` per env before each update and stops only
    between rollouts). 0 stays 0.

    Args:
        steps: the steps still wanted, in the stage's unit.
        rollout: steps per rollout, ``n_steps * n_envs`` (stage 1: every crew of every env
            copy is an env).
    """
    return -(-steps // rollout) * rollout


def learn(model, run: Run, callbacks) -> Path:
    """PPO up to ``total_steps`` rounded up to whole rollouts (``whole_rollouts``; the
    progress bar counts to that), logging to ``progress{suffix}.csv`` and ``tb/``, then
    ``final_model.zip``; Ctrl-C saves ``checkpoints/interrupted.zip`` and raises
    ``TrainingInterrupted`` saying how to resume."""
    import signal

    from stable_baselines3.common.logger import CSVOutputFormat, Logger, TensorBoardOutputFormat

    folder = run.folder
    model.set_logger(Logger(None, [CSVOutputFormat(str(folder / f"progress{run.suffix}.csv")),
                                   TensorBoardOutputFormat(str(folder / "tb"))]))
    wanted = max(0, run.config.total_steps - model.num_timesteps)
    rollout = model.n_steps * model.n_envs
    # PPO collects whole rollouts, so it runs past a total that is not a multiple of one:
    # ask for the rounded total, so that the progress bar's total is what runs.
    steps = whole_rollouts(wanted, rollout)
    rounded = (f" ({wanted:,} rounded up to whole rollouts of n_steps {model.n_steps} x "
               f"{model.n_envs} envs = {rollout:,})" if steps != wanted else "")
    run.log(f"PPO: {steps:,} {run.unit} to go{rounded}; Ctrl-C saves a checkpoint to resume "
            "from")
    try:
        model.learn(steps, callback=callbacks, reset_num_timesteps=run.resume is None,
                    progress_bar=run.progress_bar)
    except KeyboardInterrupt:
        path = folder / "checkpoints" / "interrupted.zip"
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C waits
        try:
            save_model(model, path)
        finally:
            signal.signal(signal.SIGINT, previous)
        raise TrainingInterrupted(
            f"interrupted at {model.num_timesteps:,} {run.unit} of PPO: saved {path}; "
            f"resume with --resume {path}") from None
    final = folder / "final_model.zip"
    save_model(model, final)
    return final
