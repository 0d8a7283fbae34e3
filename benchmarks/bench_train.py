"""PPO agent-steps per second on the CMDP (stage 1) and on a trivial env with the same spaces
and the same PPO settings, measured in one run, and their ratio (target 0.5 or better).

    python benchmarks/bench_train.py [--steps 100000] [--rounds 3]

The two are measured in alternating rounds (CMDP, trivial, CMDP, trivial...), each in a fresh
Python process, and the median of the per-round ratios is reported. Measured in one process
one after the other, the rounds' ratios ranged from 0.31 to 0.56 here; in fresh processes
from 0.39 to 0.42.

Both go through the same SuperSuit -> VecMonitor -> PPO pipeline with the stage-1 config
(training/configs/stage1.toml), the CMDP as training builds it (``MixedStageEnv``, lean
infos), so the ratio is what the simulator costs training.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

import cmdp_pymunk
from training.stage1 import DEFAULT_CONFIG, MixedStageEnv, Stage1Config


class TrivialEnv(ParallelEnv):
    """Seven agents, the CMDP's spaces, constant observations, zero reward, fixed length."""

    metadata = {"name": "trivial_v0", "render_modes": [], "is_parallelizable": True}

    def __init__(self, n_agents: int, obs_size: int, length: int):
        self.possible_agents = [f"a{i}" for i in range(n_agents)]
        self._obs = spaces.Box(-np.inf, np.inf, (obs_size,), np.float32)
        self._act = spaces.MultiDiscrete([4, 3, 3])
        self.length = length
        self.render_mode = None

    def observation_space(self, agent):  # the same object every call, as PettingZoo asks
        return self._obs

    def action_space(self, agent):
        return self._act

    def reset(self, seed=None, options=None):
        self.agents = list(self.possible_agents)
        self.t = 0
        zero = np.zeros(self._obs.shape, np.float32)
        return {a: zero for a in self.agents}, {a: {} for a in self.agents}

    def step(self, actions):
        self.t += 1
        done = self.t >= self.length
        zero = np.zeros(self._obs.shape, np.float32)
        out = ({a: zero for a in self.agents}, {a: 0.0 for a in self.agents},
               {a: False for a in self.agents}, {a: done for a in self.agents},
               {a: {} for a in self.agents})
        if done:
            self.agents = []
        return out


def agent_steps_per_second(env, config: Stage1Config, steps: int) -> float:
    import supersuit as ss
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor

    torch.set_num_threads(config.torch_threads)
    venv = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(env), config.n_envs,
                                 num_cpus=config.num_cpus, base_class="stable_baselines3")
    venv.venv.reset(seed=config.seed)
    model = PPO("MlpPolicy", VecMonitor(venv), learning_rate=config.learning_rate,
                n_steps=config.n_steps, batch_size=config.batch_size, n_epochs=config.n_epochs,
                policy_kwargs={"net_arch": list(config.net_arch)}, device="cpu", verbose=0)
    model.learn(config.n_steps * venv.num_envs)  # warm-up: one rollout and update
    start, done = time.perf_counter(), model.num_timesteps
    model.learn(steps, reset_num_timesteps=False)
    rate = (model.num_timesteps - done) / (time.perf_counter() - start)
    venv.close()
    return rate


def _measure_in_fresh_process(which: str, steps: int) -> float:
    import subprocess
    import sys

    out = subprocess.run([sys.executable, __file__, "--only", which, "--steps", str(steps)],
                         capture_output=True, text=True, check=True).stdout
    return float(out.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(parser)
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--only", choices=("cmdp", "trivial"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    config = Stage1Config.load(DEFAULT_CONFIG)
    case = cmdp_pymunk.load_case(config.case)
    if args.only:  # one measurement, in this (fresh) process
        env = MixedStageEnv(config, case)  # the env as training builds it
        if args.only == "trivial":
            obs_size = env.observation_space(env.possible_agents[0]).shape[0]
            env = TrivialEnv(len(case.crews), obs_size, int(config.episode_time_s))
        print(agent_steps_per_second(env, config, args.steps))
        return 0
    rates = []
    for k in range(args.rounds):
        ours, trivial = (_measure_in_fresh_process(which, args.steps)
                         for which in ("cmdp", "trivial"))
        rates.append((ours, trivial))
        print(f"round {k + 1}: CMDP {ours:8,.0f}, trivial {trivial:8,.0f} agent-steps/s, "
              f"ratio {ours / trivial:.2f}", flush=True)
    ours, trivial = (float(np.median([r[i] for r in rates])) for i in (0, 1))
    print(f"PPO on the CMDP (stage 1): {ours:8,.0f} agent-steps/s (median of {args.rounds})")
    print(f"PPO on a trivial env:      {trivial:8,.0f} agent-steps/s "
          f"(same spaces, {config.n_envs} copies, {config.num_cpus} processes)")
    ratio = float(np.median([o / t for o, t in rates]))
    print(f"ratio: {ratio:.2f}, median of the rounds' ratios (target 0.5 or better)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
