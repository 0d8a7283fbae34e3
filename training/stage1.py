"""Stage 1 (section 4.2): train the shared target-reaching policy with SB3 PPO via SuperSuit.

    cmdp-train stage1 [--config training/configs/stage1.toml] [--set key=value ...]
                      [--out runs/stage1] [--resume CHECKPOINT.zip]

Data flow: ``CMDPEnv(stage=1)`` (no durations, unlimited stock, no crane wait; with
``stage2_share`` > 0, a share of full-CMDP episodes mixed in: ``MixedStageEnv``) ->
``pettingzoo_env_to_vec_env_v1`` -> ``concat_vec_envs_v1`` -> ``VecMonitor`` -> one PPO MLP whose
weights every crew shares. Optional warm start: behaviour cloning from the scripted navigator
(``bc_samples`` > 0), then PPO.

The run folder gets ``config.json`` (every setting, the seed, the case, the package versions,
the command), ``case.json``, TensorBoard logs (``tb/``, with the team's metrics under
``cmdp/``: reach rate, steps per reach, collisions and congestion entries per reach),
``progress.csv``, checkpoints, ``best_model.zip`` (best evaluation reach rate on fixed seeds),
``final_model.zip`` and ``training_curve.png``. Ctrl-C saves ``checkpoints/interrupted.zip``.
"""

from __future__ import annotations

import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import cmdp_pymunk
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.move import STAND_STILL
from cmdp_pymunk.rollout import reach_rate, versions

from .config import Count, CountOrZero, Rate, RateOrZero, RunConfig, Share, Sizes

DEFAULT_CONFIG = Path(__file__).with_name("configs") / "stage1.toml"


class Stage1Config(RunConfig):
    """Every setting of a stage-1 run; the TOML config file and ``--set`` override these."""

    case: str | None = None  # case file; None: the built-in case
    seed: CountOrZero = 0
    total_steps: Count = 3_000_000  # agent-steps (every crew's step counts)
    episode_time_s: Rate = 1500.0  # stage-1 episodes are cut here
    n_envs: Count = 8  # env copies (each gives one sample per crew per step)
    num_cpus: Count = 2  # processes stepping the copies (1: all in this process)
    torch_threads: Count = 1
    # PPO (Eq. 8 is SB3's ppo.py)
    learning_rate: Rate = 3e-4
    n_steps: Count = 256  # per env copy and crew before each update
    batch_size: Count = 2048
    n_epochs: Count = 4
    gamma: RateOrZero = 0.99
    gae_lambda: RateOrZero = 0.95
    clip_range: RateOrZero = 0.2
    ent_coef: RateOrZero = 0.003
    vf_coef: RateOrZero = 0.5
    net_arch: Sizes = [128, 128]
    # warm start: behaviour cloning from the scripted navigator
    bc_samples: CountOrZero = 300_000
    bc_epochs: CountOrZero = 6
    bc_batch_size: Count = 1024
    bc_learning_rate: Rate = 1e-3
    # stage-2 episodes in the mix (MixedStageEnv): their share of the resets, from which
    # agent-step of the run, and where they are cut
    stage2_share: Share = 0.0
    stage2_after_steps: CountOrZero = 0
    stage2_episode_time_s: Rate = 20000.0
    # the env's stall guard: an episode in which no task moves on for this long is cut and
    # counted (cmdp/stalled_episodes); 0 turns it off
    stall_s: RateOrZero = 3600.0
    # evaluation, checkpoints
    eval_every_steps: Count = 250_000
    eval_seeds: Sizes = [1000, 1001]
    checkpoint_every_steps: Count = 250_000

# -- environment -------------------------------------------------------------------------------

def make_env(config: Stage1Config, case, stage: int = 1, seed: int | None = None):
    from agents.priority import PriorityEvaluator

    return cmdp_pymunk.parallel_env(case=case, stage=stage, seed=seed,
                                    evaluator=PriorityEvaluator(),
                                    max_time_s=config.episode_time_s)


class MixedStageEnv(cmdp_pymunk.CMDPEnv):
    """Stage-1 episodes and, once the run has done ``stage2_after_steps`` agent-steps, a share
    ``stage2_share`` of full-CMDP (stage-2) episodes, drawn at each reset from the episode's
    generator.

    Stage 1 never shows what stage 2 is full of: task areas that stay up for hours, crews
    tasking inside them, and paused tasks whose own area the crew must re-enter after fetching.
    The copies of a vector env step in lockstep, so a copy's own ``step`` calls times the number
    of copies and crews is the run's agent-step count (``start_steps`` on a resumed run).
    """

    def __init__(self, config: Stage1Config, case, start_steps: int = 0, **kwargs):
        from agents.priority import PriorityEvaluator

        super().__init__(case=case, stage=1, evaluator=PriorityEvaluator(),
                         max_time_s=config.episode_time_s, lean_infos=True,
                         stall_s=config.stall_s or None, **kwargs)
        self.config = config
        self.run_steps = start_steps
        self.steps_per_call = config.n_envs * len(self.possible_agents)
        self._mix_rng = np.random.default_rng(kwargs.get("seed"))  # its own stream: the stage

    def reset(self, seed=None, options=None):
        c = self.config
        if seed is not None:
            self._mix_rng = np.random.default_rng(seed)
        draw = self._mix_rng.random()
        stage2 = self.run_steps >= c.stage2_after_steps and draw < c.stage2_share
        self.stage = 2 if stage2 else 1
        self.max_time_s = c.stage2_episode_time_s if stage2 else c.episode_time_s
        return super().reset(seed=seed, options=options)

    def step(self, actions):
        self.run_steps += self.steps_per_call
        return super().step(actions)


def make_vec_env(config: Stage1Config, case, start_steps: int = 0):
    import supersuit as ss
    from stable_baselines3.common.vec_env import VecMonitor

    env = MixedStageEnv(config, case, start_steps)  # not reset: its copies are pickled from it
    venv = ss.pettingzoo_env_to_vec_env_v1(env)
    with warnings.catch_warnings():
        # SuperSuit's process pool has no render_mode for SB3 to read; training renders nothing
        warnings.filterwarnings("ignore", "The `render_mode` attribute is not defined")
        venv = ss.concat_vec_envs_v1(venv, config.n_envs, num_cpus=config.num_cpus,
                                     base_class="stable_baselines3")
        # SB3's PPO(seed=) does not reach SuperSuit's vector env; seed the copies directly
        # (copy i gets seed + i).
        venv.venv.reset(seed=config.seed)
        return VecMonitor(venv)


# -- behaviour cloning from the navigator -----------------------------------------------------

SEARCH_TURN = (0, 1, 2)  # stand and turn anticlockwise


def teacher_action(env, agent: str, navigator_action) -> tuple:
    """The navigator's action, except that a crew holding no target turns in place.

    The rays cannot tell "no target" from "a target out of view" (both read V = 0 on every
    ray), so the navigator's standing idle would teach the policy to stand whenever its target
    is behind it. Turning finds a target behind within a turn, and costs an idle crew nothing.
    """
    crew = env.site.crews[env.agent_index[agent]]
    return navigator_action if crew.scope else SEARCH_TURN


def navigator_samples(config: Stage1Config, case, n: int, seed: int) -> tuple:
    """(observations, actions) of the scripted navigator on stage-1 episodes.

    DAgger (the clone drives, the navigator labels the states it visits) was tried on the
    built-in case and made the clone worse (stage-2 reach rate 0.75-0.83 after two rounds
    against 0.89-0.91 for plain cloning): the navigator's answers in the clone's states lean on
    its own re-planning memory and the map, which the rays cannot show.
    """
    from agents.navigator import Navigator

    env = make_env(config, case, seed=seed)
    obs_out, act_out = [], []
    episode = 0
    while len(obs_out) < n:
        observations, infos = env.reset(seed=seed + episode)
        navigator = Navigator(env)
        while env.agents and len(obs_out) < n:
            actions = navigator.actions(env, observations)
            for agent in env.agents:
                if infos[agent]["needs_action"]:
                    obs_out.append(observations[agent])
                    act_out.append(teacher_action(env, agent, actions.get(agent, STAND_STILL)))
            observations, _, _, _, infos = env.step(actions)
        episode += 1
    return np.asarray(obs_out, dtype=np.float32), np.asarray(act_out, dtype=np.int64)


def behaviour_clone(model, observations, actions, config: Stage1Config, log=print) -> float:
    """Fit the policy's action distribution to the navigator's actions (cross-entropy)."""
    import torch

    policy = model.policy
    optimizer = torch.optim.Adam(policy.parameters(), lr=config.bc_learning_rate)
    rng = np.random.default_rng(config.seed)
    obs_t = torch.as_tensor(observations)
    act_t = torch.as_tensor(actions)
    loss_value = float("nan")
    for epoch in range(config.bc_epochs):
        order = rng.permutation(len(obs_t))
        losses = []
        for start in range(0, len(order), config.bc_batch_size):
            idx = torch.as_tensor(order[start:start + config.bc_batch_size])
            _, log_prob, _ = policy.evaluate_actions(obs_t[idx], act_t[idx])
            loss = -log_prob.mean()
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            losses.append(loss.item())
        loss_value = float(np.mean(losses))
        with torch.no_grad():
            dist = policy.get_distribution(obs_t[:20000])
            pred = dist.mode() if hasattr(dist, "mode") else dist.get_actions(deterministic=True)
            agree = (pred.numpy() == actions[:20000]).all(axis=1).mean()
        log(f"behaviour cloning epoch {epoch + 1}/{config.bc_epochs}: loss {loss_value:.3f}, "
            f"agreement with the navigator {agree:.1%}")
    return loss_value


# -- evaluation ---------------------------------------------------------------------------------

def evaluate_reaching(model, config: Stage1Config, case, seeds, stage: int = 1) -> dict:
    """Episodes on fixed seeds, actions sampled with a seeded generator (the deterministic
    argmax policy tends to repeat a blocked move): reach rate within the step cap, reward,
    share of tasks done."""
    from agents.models import PolicyNavigator

    navigator = PolicyNavigator.from_model(model, deterministic=False)
    reaches = timeouts = steps = 0
    rewards, tasks = [], []
    for seed in seeds:
        env = make_env(config, case, stage=stage, seed=seed)
        observations, _ = env.reset(seed=seed)
        navigator.reset(seed)
        total = 0.0
        while env.agents:
            observations, rew, *_ = env.step(navigator.actions(env, observations))
            total += sum(rew.values())
        for crew in env.site.crews:
            reaches += crew.stats.reaches
            timeouts += crew.stats.reach_timeouts
            steps += crew.stats.reaching_steps
        rewards.append(total)
        tasks.append(env.site.tasks_ended / len(env.site.tasks))
    return {"reach_rate": reach_rate(reaches, timeouts),
            "steps_per_reach": steps / max(1, reaches),
            "mean_reward": float(np.mean(rewards)), "tasks_done": float(np.mean(tasks))}


# -- callbacks ----------------------------------------------------------------------------------

def make_callbacks(config: Stage1Config, case, run: Path):
    from stable_baselines3.common.callbacks import BaseCallback

    n_agents = len(case.crews)

    class Metrics(BaseCallback):
        """The team's metrics from the env infos, logged per rollout."""

        def _on_rollout_start(self) -> None:
            self.sums = dict.fromkeys(("reaches", "timeouts", "reaching", "collisions",
                                       "congestion", "stalled"), 0)

        def _on_step(self) -> bool:
            for info in self.locals["infos"]:
                s = info.get("step_stats")
                if s:
                    for k, v in s.items():
                        self.sums[k] += v
                if info.get("stalled"):  # every crew of a stalled episode carries the flag
                    self.sums["stalled"] += 1
            return True

        def _on_rollout_end(self) -> None:
            s = self.sums
            reaches = max(1, s["reaches"])
            self.logger.record("cmdp/reach_rate", reach_rate(s["reaches"], s["timeouts"]))
            self.logger.record("cmdp/steps_per_reach", s["reaching"] / reaches)
            self.logger.record("cmdp/collisions_per_reach", s["collisions"] / reaches)
            self.logger.record("cmdp/congestion_entries_per_reach", s["congestion"] / reaches)
            self.logger.record("cmdp/reaches", s["reaches"])
            # episodes the env's stall guard cut short (no task moved on for stall_s)
            self.logger.record("cmdp/stalled_episodes", s["stalled"] / n_agents)

    class Periodic(BaseCallback):
        """Checkpoints and evaluation on fixed seeds, keeping the best model."""

        def __init__(self):
            super().__init__()
            self.best = -1.0
            self.next_eval = config.eval_every_steps
            self.next_ckpt = config.checkpoint_every_steps

        def _init_callback(self) -> None:
            done = self.model.num_timesteps
            self.next_eval = (done // config.eval_every_steps + 1) * config.eval_every_steps
            self.next_ckpt = (done // config.checkpoint_every_steps + 1) * \
                config.checkpoint_every_steps
            best_file = run / "best.json"
            if best_file.exists():
                self.best = json.loads(best_file.read_text())["score"]

        def _on_step(self) -> bool:
            t = self.model.num_timesteps
            if t >= self.next_ckpt:
                self.next_ckpt += config.checkpoint_every_steps
                save_model(self.model, run / "checkpoints" / f"step_{t}.zip")
            if t >= self.next_eval:
                self.next_eval += config.eval_every_steps
                result = evaluate_reaching(self.model, config, case, config.eval_seeds)
                for k, v in result.items():
                    self.logger.record(f"eval/{k}", v)
                print(f"\nevaluation at {t:,} steps: " + ", ".join(
                    f"{k} {v:.3f}" for k, v in result.items()), flush=True)
                score = result["reach_rate"] + 1e-3 * result["mean_reward"] / n_agents
                if score > self.best:
                    self.best = score
                    save_model(self.model, run / "best_model.zip")
                    write_atomic(run / "best.json", json.dumps(
                        {"step": t, "score": score, **result}, indent=2))
            return True

    return [Metrics(), Periodic()]


def _next_part(run: Path) -> int:
    """1 + the number of resumed parts already in the run folder."""
    return 1 + sum(1 for _ in run.glob("progress-*.csv"))


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


def learn(model, total_steps: int, callbacks, run: Path, suffix: str, fresh: bool,
          progress_bar: bool, unit: str, log=print) -> Path:
    """PPO up to ``total_steps`` ``unit``, logging to ``progress{suffix}.csv`` and ``tb/``,
    then ``final_model.zip``; Ctrl-C saves ``checkpoints/interrupted.zip`` and raises
    ``TrainingInterrupted`` saying how to resume."""
    import signal

    from stable_baselines3.common.logger import CSVOutputFormat, Logger, TensorBoardOutputFormat

    model.set_logger(Logger(None, [CSVOutputFormat(str(run / f"progress{suffix}.csv")),
                                   TensorBoardOutputFormat(str(run / "tb"))]))
    steps = max(0, total_steps - model.num_timesteps)
    log(f"PPO: {steps:,} {unit} to go (Ctrl-C saves a checkpoint to resume from)")
    try:
        model.learn(steps, callback=callbacks, reset_num_timesteps=fresh,
                    progress_bar=progress_bar)
    except KeyboardInterrupt:
        path = run / "checkpoints" / "interrupted.zip"
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C waits
        try:
            save_model(model, path)
        finally:
            signal.signal(signal.SIGINT, previous)
        raise TrainingInterrupted(
            f"interrupted at {model.num_timesteps:,} {unit} of PPO: saved {path}; "
            f"resume with --resume {path}") from None
    final = run / "final_model.zip"
    save_model(model, final)
    return final


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


# -- main ---------------------------------------------------------------------------------------

def train(config: Stage1Config, run: Path, resume: Path | None = None, argv=None,
          progress_bar: bool = True, log=print) -> Path:
    """Train (or resume) a stage-1 run in ``run``; returns the final model's path.

    Ctrl-C raises ``TrainingInterrupted``: during PPO after saving
    ``checkpoints/interrupted.zip`` to resume from; during behaviour cloning nothing can be
    saved yet."""

    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.utils import set_random_seed

    torch.set_num_threads(config.torch_threads)
    torch.distributions.Distribution.set_default_validate_args(False)
    case = cmdp_pymunk.load_case(config.case)
    run.mkdir(parents=True, exist_ok=True)
    part = _next_part(run) if resume is not None else 0  # a resumed run adds files, never
    suffix = f"-{part}" if part else ""                   # overwrites the history
    write_atomic(run / f"config{suffix}.json", json.dumps(
        {"config": config.model_dump(), "command": argv, "resumed_from": str(resume) if resume
         else None, "versions": versions()}, indent=2))
    write_atomic(run / "case.json", json.dumps(case.model_dump(mode="json"), indent=2))
    set_random_seed(config.seed)
    start_steps = 0
    if resume is not None:
        from stable_baselines3.common.save_util import load_from_zip_file

        start_steps = load_from_zip_file(str(resume), device="cpu")[0]["num_timesteps"]
    venv = without_sigint(lambda: make_vec_env(config, case, start_steps))
    try:
        if resume is not None:
            # a checkpoint of the v0 env saved an unbounded observation space of the same shape
            model = PPO.load(str(resume), env=venv, device="cpu",
                             custom_objects={"observation_space": venv.observation_space})
            log(f"resumed from {resume} at {model.num_timesteps:,} steps")
        else:
            model = PPO("MlpPolicy", venv, learning_rate=config.learning_rate,
                        n_steps=config.n_steps, batch_size=config.batch_size,
                        n_epochs=config.n_epochs, gamma=config.gamma,
                        gae_lambda=config.gae_lambda, clip_range=config.clip_range,
                        ent_coef=config.ent_coef, vf_coef=config.vf_coef,
                        policy_kwargs={"net_arch": list(config.net_arch)}, device="cpu",
                        verbose=0)
            if config.bc_samples > 0:
                try:
                    log(f"behaviour cloning: collecting {config.bc_samples:,} decisions of "
                        "the scripted navigator")
                    t0 = time.perf_counter()
                    obs, acts = navigator_samples(config, case, config.bc_samples,
                                                  config.seed + 10_000)
                    log(f"behaviour cloning: {len(obs):,} navigator samples in "
                        f"{time.perf_counter() - t0:.0f} s")
                    behaviour_clone(model, obs, acts, config, log)
                except KeyboardInterrupt:
                    raise TrainingInterrupted(
                        "interrupted during behaviour cloning (the warm start before PPO): "
                        f"nothing could be saved yet, there is no model before it ends; "
                        f"{run} holds only config{suffix}.json and case.json; start again "
                        "with the same command (or --set bc_samples=0 to skip cloning)"
                    ) from None
        final = learn(model, config.total_steps, make_callbacks(config, case, run), run,
                      suffix, resume is None, progress_bar, "agent-steps", log)
    finally:
        venv.close()
    from media.curves import draw_training_curve

    draw_curve(draw_training_curve, run, log)
    return final


def draw_curve(draw, run: Path, log=print) -> None:
    """``training_curve.png`` from every ``progress*.csv`` of the run (its resumed parts)."""
    try:
        draw(sorted(run.glob("progress*.csv")), run / "training_curve.png")
    except (FileNotFoundError, ValueError) as err:
        log(f"no training curve: {err}")


def main(argv: list[str] | None = None) -> int:
    import argparse

    parser = argparse.ArgumentParser(prog="cmdp-train", description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(parser)
    sub = parser.add_subparsers(dest="stage", required=True)
    for stage, what in (("stage1", "the shared target-reaching policy (section 4.2)"),
                        ("stage2", "the target-evaluation policy (section 3.6.1)")):
        p = sub.add_parser(stage, help=f"train {what}")
        p.add_argument("--config", type=Path, default=None,
                       help=f"TOML settings (default: training/configs/{stage}.toml)")
        p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                       help="override a config setting (repeatable)")
        p.add_argument("--out", type=Path, default=Path(f"runs/{stage}"),
                       help=f"run folder (default: runs/{stage})")
        p.add_argument("--resume", type=Path, default=None, help="a checkpoint .zip to resume")
        p.add_argument("--no-progress", action="store_true")
    args = parser.parse_args(argv)
    argv = argv if argv is not None else sys.argv[1:]
    if args.stage == "stage2":
        from . import stage2

        return run_guarded(lambda: start(stage2.Stage2Config, stage2.DEFAULT_CONFIG,
                                         stage2.train, args, argv))
    return run_guarded(lambda: start(Stage1Config, DEFAULT_CONFIG, train, args, argv))


def start(config_class, default_config: Path, train_run, args, argv) -> Path | int:
    """Settings checked, then ``train_run``: the final model's path, or 2 with one line for
    bad settings (``main`` runs this under its Ctrl-C guard)."""
    try:
        config = config_class.load(args.config or default_config, args.set)
        cmdp_pymunk.load_case(config.case)
        if args.resume is not None and not args.resume.is_file():
            raise ValueError(f"--resume {args.resume}: no such checkpoint")
    except (cmdp_pymunk.CaseError, ValueError, TypeError) as err:
        print(f"cmdp-train: {err}", file=sys.stderr)
        return 2
    return train_run(config, args.out, args.resume, argv=argv, progress_bar=not args.no_progress)


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
