"""Stage 1 (section 4.2): train the shared target-reaching policy with SB3 PPO via SuperSuit.

    cmdp-train stage1 [--config training/configs/stage1.toml] [--set key=value ...]
                      [--out runs/stage1] [--resume CHECKPOINT.zip]

Data flow: ``CMDPEnv(stage=1)`` (no durations, unlimited stock, no crane wait; with
``stage2_share`` > 0, a share of full-CMDP episodes mixed in: ``MixedStageEnv``) ->
``pettingzoo_env_to_vec_env_v1`` -> ``concat_vec_envs_v1`` -> ``VecMonitor`` -> one PPO MLP whose
weights every crew shares. Optional warm start: behaviour cloning from the scripted navigator
(``bc_samples`` > 0), then PPO. The run itself (folder, PPO, evaluation, checkpoints, Ctrl-C,
resume, the curve) is ``training.scaffold``'s, shared with stage 2.

The run folder gets ``config.json`` (every setting, the seed, the case, the package versions,
the command), ``case.json``, TensorBoard logs (``tb/``, with the team's metrics under
``cmdp/``: reach rate, steps per reach, collisions and congestion entries per reach),
``progress.csv``, checkpoints, ``best_model.zip`` (best evaluation reach rate on fixed seeds),
``final_model.zip`` and ``training_curve.png``. Ctrl-C saves ``checkpoints/interrupted.zip``.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np

import cmdp_pymunk
from cmdp_pymunk.move import STAND_STILL
from cmdp_pymunk.report import reach_rate

from . import scaffold
from .config import CountOrZero, Rate, RateOrZero, Share

DEFAULT_CONFIG = Path(__file__).with_name("configs") / "stage1.toml"


class Stage1Config(scaffold.PPOSettings):
    """Every setting of a stage-1 run: ``scaffold.PPOSettings``' (with stage 1's values in
    ``DEFAULTS``; ``total_steps`` and the evaluation's counts are agent-steps: every crew's
    step counts) and stage 1's own; the TOML config file and ``--set`` override these."""

    DEFAULTS = {"total_steps": 3_000_000, "n_envs": 8, "num_cpus": 2,
                "learning_rate": 3e-4, "batch_size": 2048, "n_epochs": 4, "gamma": 0.99,
                "clip_range": 0.2, "ent_coef": 0.003, "bc_epochs": 6, "bc_batch_size": 1024,
                "eval_every_steps": 250_000, "eval_seeds": [1000, 1001],
                "checkpoint_every_steps": 250_000}

    episode_time_s: Rate = 1500.0  # stage-1 episodes are cut here
    # warm start: behaviour cloning from the scripted navigator, on this many of its decisions
    bc_samples: CountOrZero = 300_000
    # stage-2 episodes in the mix (MixedStageEnv): their share of the resets, from which
    # agent-step of the run, and where they are cut
    stage2_share: Share = 0.0
    stage2_after_steps: CountOrZero = 0
    stage2_episode_time_s: Rate = 20000.0
    # the env's stall guard: an episode in which no task moves on for this long is cut and
    # counted (cmdp/stalled_episodes); 0 turns it off
    stall_s: RateOrZero = 3600.0


# -- environment -------------------------------------------------------------------------------

def make_env(config: Stage1Config, case, stage: int = 1, seed: int | None = None):
    return cmdp_pymunk.parallel_env(case=case, stage=stage, seed=seed,
                                    evaluator="priority",
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
        super().__init__(case=case, stage=1, evaluator="priority",
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


def teacher_action(engine, i: int, navigator_action) -> tuple:
    """The navigator's action for crew i, except that a crew holding no target turns in place.

    The rays cannot tell "no target" from "a target out of view" (both read V = 0 on every
    ray), so the navigator's standing idle would teach the policy to stand whenever its target
    is behind it. Turning finds a target behind within a turn, and costs an idle crew nothing.
    """
    crew = engine.site.crews[i]
    return navigator_action if crew.scope else SEARCH_TURN


def navigator_samples(config: Stage1Config, case, n: int, seed: int,
                      progress: bool = False) -> tuple:
    """(observations, actions) of the scripted navigator on stage-1 episodes; ``progress``
    shows a bar of the decisions collected out of ``n`` (the warm start's longest phase).

    DAgger (the clone drives, the navigator labels the states it visits) was tried on the
    built-in case and made the clone worse (stage-2 reach rate 0.75-0.83 after two rounds
    against 0.89-0.91 for plain cloning): the navigator's answers in the clone's states lean on
    its own re-planning memory and the map, which the rays cannot show.
    """
    from tqdm import tqdm

    from agents.navigator import Navigator

    env = make_env(config, case, seed=seed)
    obs_out, act_out = [], []
    episode = 0
    bar = tqdm(total=n, unit="decision", disable=not progress, mininterval=1.0,
               desc="behaviour cloning samples")
    while len(obs_out) < n:
        observations, infos = env.reset(seed=seed + episode)
        navigator = Navigator()
        while env.agents and len(obs_out) < n:
            actions = env.agent_actions(navigator, observations)
            for agent in env.agents:
                if infos[agent]["needs_action"]:
                    obs_out.append(observations[agent])
                    act_out.append(teacher_action(env.engine, env.agent_index[agent],
                                                  actions.get(agent, STAND_STILL)))
            bar.update(min(len(obs_out), n) - bar.n)
            observations, _, _, _, infos = env.step(actions)
        episode += 1
    bar.close()
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
            observations, rew, *_ = env.step(env.agent_actions(navigator, observations))
            total += sum(rew.values())
        site = env.engine.site
        for crew in site.crews:
            reaches += crew.stats.reaches
            timeouts += crew.stats.reach_timeouts
            steps += crew.stats.reaching_steps
        rewards.append(total)
        tasks.append(site.tasks_ended / len(site.tasks))
    return {"reach_rate": reach_rate(reaches, timeouts),
            "steps_per_reach": steps / max(1, reaches),
            "mean_reward": float(np.mean(rewards)), "tasks_done": float(np.mean(tasks))}


# -- metrics ----------------------------------------------------------------------------------

def metrics_callback(n_agents: int):
    """An SB3 callback: the team's metrics from the env infos, logged per rollout."""
    from stable_baselines3.common.callbacks import BaseCallback

    class Metrics(BaseCallback):
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

    return Metrics()


# -- main ---------------------------------------------------------------------------------------

def train(config: Stage1Config, run: Path, resume: Path | None = None, argv=None,
          progress_bar: bool = True, log=scaffold.say) -> Path:
    """Train (or resume) a stage-1 run in ``run`` (``scaffold.train_ppo``); returns the final
    model's path.

    Ctrl-C raises ``scaffold.TrainingInterrupted``: during PPO after saving
    ``checkpoints/interrupted.zip`` to resume from; during behaviour cloning nothing can be
    saved yet."""
    from media.curves import draw_training_curve

    case = cmdp_pymunk.load_case(config.case)
    n_agents = len(case.crews)
    start_steps = scaffold.steps_done(resume)

    def warm_start(model) -> None:
        log(f"behaviour cloning: collecting {config.bc_samples:,} decisions of the scripted "
            "navigator")
        t0 = time.perf_counter()
        obs, acts = navigator_samples(config, case, config.bc_samples, config.seed + 10_000,
                                      progress_bar)
        log(f"behaviour cloning: {len(obs):,} navigator samples in "
            f"{time.perf_counter() - t0:.0f} s")
        behaviour_clone(model, obs, acts, config, log)

    evaluation = scaffold.Evaluation(
        play=lambda model: evaluate_reaching(model, config, case, config.eval_seeds),
        describe=lambda result: ", ".join(f"{k} {v:.3f}" for k, v in result.items()),
        score=lambda result: result["reach_rate"] + 1e-3 * result["mean_reward"] / n_agents)
    return scaffold.train_ppo(
        scaffold.Run(config, case, run, "agent-steps", resume, argv, progress_bar, log),
        make_venv=lambda: make_vec_env(config, case, start_steps),
        new_model=lambda venv: scaffold.new_ppo(config, "MlpPolicy", venv,
                                                {"net_arch": list(config.net_arch)}),
        warm_start=warm_start if config.bc_samples > 0 else None,
        skip_warm_start="bc_samples=0", metrics=metrics_callback(n_agents),
        evaluation=evaluation, draw_curve=draw_training_curve,
        # a checkpoint of the v0 env saved an unbounded observation space of the same shape
        env_space_on_resume=True)
