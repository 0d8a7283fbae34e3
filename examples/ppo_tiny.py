"""Two minutes of PPO (Stable-Baselines3) on ``cmdp/TinyFloor-v1``: one reaching policy shared by
every crew (parameter sharing through SuperSuit), as stage 1 of the paper trains it.

    python examples/ppo_tiny.py                      # about 2 minutes on one core
    python examples/ppo_tiny.py --seconds 10         # a smoke run

Each crew is one sample of a shared policy: SuperSuit turns the PettingZoo env into an SB3
vector env with one slot per crew. The run stops after ``--steps`` agent-steps or
``--seconds`` of wall time, whichever comes first, then plays one episode with the policy and
one with random actions and prints both returns. For the project's full training (behaviour
cloning warm start, evaluation, checkpoints, resume) use ``cmdp-train stage1``.
"""

import argparse
import time

import numpy as np
import pettingzoo
import supersuit as ss
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.utils import set_random_seed

import cmdp_pymunk  # noqa: F401  (registers the cmdp/ variants)


class WallClock(BaseCallback):
    """Stops learning after ``seconds`` of wall time."""

    def __init__(self, seconds: float):
        super().__init__()
        self.deadline = time.monotonic() + seconds

    def _on_step(self) -> bool:
        return time.monotonic() < self.deadline


def episode_return(env_id: str, seed: int, policy, steps: int) -> float:
    """Mean return per crew of one episode of at most ``steps`` steps."""
    env = pettingzoo.make("parallel", env_id, seed=seed)
    observations, _ = env.reset(seed=seed)
    total = dict.fromkeys(env.agents, 0.0)
    for _ in range(steps):
        if not env.agents:
            break
        observations, rewards, *_ = env.step({a: policy(a, observations[a], env)
                                              for a in env.agents})
        for agent, reward in rewards.items():
            total[agent] += reward
    return float(np.mean(list(total.values())))


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", default="cmdp/TinyFloor-v1")
    p.add_argument("--steps", type=int, default=200_000, help="agent-steps at most")
    p.add_argument("--seconds", type=float, default=120.0, help="wall-clock seconds at most")
    p.add_argument("--eval-steps", type=int, default=1500, help="env steps of each evaluation")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)

    set_random_seed(args.seed)  # PPO(seed=...) fails on SuperSuit's vec env (shared/PITFALLS.md)
    env = pettingzoo.make("parallel", args.env, seed=args.seed)
    venv = ss.pettingzoo_env_to_vec_env_v1(env)
    venv = ss.concat_vec_envs_v1(venv, 1, num_cpus=0, base_class="stable_baselines3")
    model = PPO("MlpPolicy", venv, n_steps=256, batch_size=256, n_epochs=4,
                learning_rate=3e-4, ent_coef=0.003, policy_kwargs={"net_arch": [64, 64]},
                device="cpu", verbose=0)
    start = time.monotonic()
    model.learn(total_timesteps=args.steps, callback=WallClock(args.seconds))
    print(f"trained {model.num_timesteps:,} agent-steps in {time.monotonic() - start:.0f} s")

    trained = episode_return(args.env, args.seed + 1,
                             lambda a, obs, env: model.predict(obs, deterministic=False)[0],
                             args.eval_steps)
    rng = np.random.default_rng(args.seed)
    random = episode_return(args.env, args.seed + 1,
                            lambda a, obs, env: rng.integers(env.action_space(a).nvec),
                            args.eval_steps)
    print(f"return per crew over {args.eval_steps} steps: PPO {trained:.2f}, random {random:.2f}")
    return {"steps": model.num_timesteps, "ppo": trained, "random": random}


if __name__ == "__main__":
    main()
