"""Stage-2 training with its floors in this process, in local worker processes and on Ray
actors on the same cores, in one run: decisions per second of the vector env stepped alone
and of PPO learning through it, with the ratios.

    python benchmarks/bench_ray_train.py [--n-envs 4] [--cpus 2] [--decisions 512]
                                         [--n-steps 64] [--rounds 2]

Needs Ray (``pip install -e '.[ray]'``). The floors are ``cmdp-train stage2``'s (built-in
case, scripted low level, the central critic's global state; ``training/configs/stage2.toml``
with ``n_envs``, ``num_cpus`` and ``n_steps`` from the options), built by
``stage2.make_vec_env`` as training builds them: ``--n-envs`` floors in this process
(``FloorsVecEnv``), in ``--cpus`` worker processes (``ProcessGroupsVecEnv``) and on ``--cpus``
Ray actors (``ray_vec_env.RayGroupsVecEnv``, a Ray started here with ``--cpus`` CPUs). For
each: the seconds to build it; ``--decisions`` decisions of uniformly random desired
positions (the vector env alone); then PPO (``scaffold.new_ppo`` with the stage's settings and
policy) learning one rollout of warm-up and ``--decisions`` more, timed (sampling and
updates: what ``cmdp-train stage2`` does). Rounds alternate the order; medians and their
ratios to this process are printed, then Ray against local processes on the same cores. The
random decisions are checked to give the same rewards on every backend.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import cmdp_pymunk
from cmdp_pymunk.report import versions
from training import scaffold, stage2


def build(config, case, ray: str | None):
    start = time.perf_counter()
    venv = stage2.make_vec_env(config, case, config.seed, ray)
    return venv, time.perf_counter() - start


def step_alone(venv, decisions: int, seed: int) -> tuple[float, float]:
    """Decisions per second of random desired positions, and the sum of their rewards."""
    n = venv.num_envs
    actions = np.random.default_rng(seed).uniform(-1, 1, (decisions // n, n, 2)).astype(
        np.float32)
    venv.reset()
    start = time.perf_counter()
    total = 0.0
    for a in actions:
        _, rewards, _, _ = venv.step(a)
        total += float(rewards.sum())
    return len(actions) * n / (time.perf_counter() - start), total


def learn(venv, config, decisions: int) -> float:
    """PPO decisions per second over ``decisions`` after one rollout and update."""
    from agents.central_critic import CentralCriticPolicy

    venv.seed(config.seed)
    policy_kwargs = {"net_arch": list(config.net_arch), "log_std_init": config.log_std_init,
                     "actor_size": venv.get_attr("actor_size", [0])[0]}
    model = scaffold.new_ppo(config, CentralCriticPolicy, venv, policy_kwargs,
                             seed=config.seed)
    model.learn(config.n_steps * venv.num_envs)
    start, done = time.perf_counter(), model.num_timesteps
    model.learn(decisions, reset_num_timesteps=False)
    return (model.num_timesteps - done) / (time.perf_counter() - start)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--n-envs", type=int, default=4, help="floors (env copies)")
    p.add_argument("--cpus", type=int, default=2, help="local processes, Ray CPUs and actors")
    p.add_argument("--decisions", type=int, default=512, help="decisions measured per part")
    p.add_argument("--n-steps", type=int, default=64, help="PPO's decisions per floor and update")
    p.add_argument("--rounds", type=int, default=2)
    a = p.parse_args(argv)
    import torch

    from training.runs.ray_backend import connect, ray

    torch.set_num_threads(1)
    commit = (versions()["commit"] or "unknown")[:7]
    print(f"commit {commit}, {len(os.sched_getaffinity(0))} cores, load "
          f"{os.getloadavg()[0]:.1f}", flush=True)
    start = time.perf_counter()
    connect("local", a.cpus)
    print(f"Ray {ray.__version__} started here with {a.cpus} CPUs in "
          f"{time.perf_counter() - start:.1f} s", flush=True)
    overrides = [f"n_envs={a.n_envs}", f"n_steps={a.n_steps}"]
    base = stage2.Stage2Config.load(stage2.DEFAULT_CONFIG, [*overrides, "num_cpus=1"])
    case = stage2.training_case(base)
    spread = base.model_copy(update={"num_cpus": a.cpus})
    backends = [("this process", base, None), (f"local {a.cpus}", spread, None),
                (f"Ray {a.cpus}", spread, "local")]
    speed = {name: {"step": [], "learn": []} for name, _, _ in backends}
    sums = {}
    try:
        for r in range(a.rounds):
            for name, config, where in backends if r % 2 == 0 else backends[::-1]:
                venv, up = build(config, case, where)
                try:
                    rate, sums[name] = step_alone(venv, a.decisions, r)
                    speed[name]["step"].append(rate)
                    speed[name]["learn"].append(learn(venv, config, a.decisions))
                finally:
                    venv.close()
                print(f"round {r}: {name}: built in {up:.1f} s; vector env alone "
                      f"{rate:.1f} decisions/s; PPO {speed[name]['learn'][-1]:.1f} decisions/s",
                      flush=True)
            assert len(set(sums.values())) == 1, f"the backends disagree: {sums}"
    finally:
        ray.shutdown()
    med = {name: {k: statistics.median(v) for k, v in parts.items()}
           for name, parts in speed.items()}
    here, local, on_ray = (name for name, _, _ in backends)
    for part, what in (("step", "vector env alone"), ("learn", "PPO learning")):
        print(f"{what}: median " + ", ".join(
            f"{name} {m[part]:.1f} decisions/s ({m[part] / med[here][part]:.2f} x)"
            for name, m in med.items())
              + f"; {on_ray} / {local} = {med[on_ray][part] / med[local][part]:.2f}")


if __name__ == "__main__":
    main()
