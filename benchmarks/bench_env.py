"""Env cost per agent-step against the raw floor of the same scene, measured in one run.

The raw floor is what any pymunk simulator of this scene must pay: ``space.step`` (with the
same substeps and velocity functions) plus 28 ``segment_query_first`` per moving crew. The env
adds decisions, construction, rewards and observation assembly on top; the ratio says how much.
Target: 1.5 or less. Rounds alternate env and floor so both see the same machine load.

    python benchmarks/bench_env.py [--steps 3000] [--rounds 5]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import cmdp_pymunk


def run_env(env, actions, n: int) -> tuple[float, int, int]:
    """Seconds for n env steps under the given random actions; agent-steps; moving crew-steps."""
    agent_steps = moving = 0
    t0 = time.perf_counter()
    for k in range(n):
        if not env.agents:
            env.reset()
        agent_steps += len(env.agents)
        moving += sum(c.moving for c in env.site.crews)
        env.step({a: actions[k % len(actions)][i] for i, a in enumerate(env.agents)})
    return time.perf_counter() - t0, agent_steps, moving


def run_floor(env, n: int, moving_per_step: float) -> float:
    """Seconds for n raw steps: space.step plus every moving crew's 28 ray queries."""
    world, sim = env.world, env.case.simulation
    rays = env.rays
    crews = [c.index for c in env.site.crews if c.status.name != "LEFT"]
    n_moving = max(1, round(moving_per_step))
    query = world.space.segment_query_first
    t0 = time.perf_counter()
    for k in range(n):
        world.step(sim.step_s, sim.physics_substeps)
        for j in range(n_moving):
            i = crews[(k + j) % len(crews)]
            body = world.bodies[i]
            x, y = body.position
            c, s = math.cos(body.angle), math.sin(body.angle)
            flt = world.frontal_filters[i]
            for ux, uy, length, _ in rays.rays:
                query((x, y), (x + (c * ux - s * uy) * length, y + (s * ux + c * uy) * length),
                      0.0, flt)
    return time.perf_counter() - t0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(parser)
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args(argv)
    env = cmdp_pymunk.parallel_env(seed=0)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = rng.integers(0, [4, 3, 3], size=(1000, len(env.possible_agents), 3))
    env_s = floor_s = 0.0
    agent_steps = moving = 0
    run_env(env, actions, 200)  # warm-up
    for _ in range(args.rounds):
        dt, a, m = run_env(env, actions, args.steps)
        env_s, agent_steps, moving = env_s + dt, agent_steps + a, moving + m
        floor_s += run_floor(env, args.steps, m / args.steps)
    steps = args.steps * args.rounds
    print(f"built-in case, random actions, {steps} env steps, {agent_steps} agent-steps, "
          f"{moving / steps:.2f} moving crews a step")
    print(f"env:   {env_s / agent_steps * 1e6:8.1f} us per agent-step "
          f"({env_s / steps * 1e6:.0f} us per step)")
    print(f"floor: {floor_s / agent_steps * 1e6:8.1f} us per agent-step "
          f"(space.step + {env.rays.n_rays} segment_query_first per moving crew)")
    print(f"ratio env / floor: {env_s / floor_s:.2f} (target 1.5 or less)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
