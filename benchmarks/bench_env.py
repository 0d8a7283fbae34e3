"""Env cost per agent-step against the raw floor of the same scene, measured in one run.

The raw floor is what any pymunk simulator of this scene must pay: ``space.step`` (with the
same substeps and velocity functions) plus 28 ``segment_query_first`` per moving crew. It is a
plane of its own (``world.World`` with pymunk's public ray query, driven through the
``physics.Physics`` protocol as the engine drives it, every crew at a constant random
velocity); the env's plane stays the engine's. The env adds decisions, construction, rewards
and observation assembly on top; the ratio says how much. Target: 1.5 or less. Rounds
alternate env and floor so both see the same machine load.

    python benchmarks/bench_env.py [--steps 3000] [--rounds 5]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import cmdp_pymunk
from cmdp_pymunk.state import Site
from cmdp_pymunk.world import World


def run_env(env, actions, n: int) -> tuple[float, int, int]:
    """Seconds for n env steps under the given random actions; agent-steps; moving crew-steps."""
    agent_steps = moving = 0
    t0 = time.perf_counter()
    for k in range(n):
        if not env.agents:
            env.reset()
        agent_steps += len(env.agents)
        moving += sum(c.moving for c in env.engine.site.crews)
        env.step({a: actions[k % len(actions)][i] for i, a in enumerate(env.agents)})
    return time.perf_counter() - t0, agent_steps, moving


def raw_floor(case, rng) -> World:
    """The scene's plane alone, pymunk's public ray query, each crew driven at a constant
    random velocity (into the walls: the physics steps every time)."""
    world = World(case, Site(case, 2), public_rays=True)
    for i, crew in enumerate(case.crews):
        v = case.crew_types[crew.type].velocity_m_s
        vx, vy, omega = rng.uniform(-1.0, 1.0, 3)
        world.drive(i, vx * v, vy * v, omega)
    return world


def run_floor(world, env, n: int, moving_per_step: float) -> float:
    """Seconds for n raw steps: space.step plus every moving crew's 28 ray queries."""
    sim, rays = env.engine.case.simulation, env.rays
    crews = list(range(len(env.possible_agents)))
    n_moving = max(1, round(moving_per_step))
    t0 = time.perf_counter()
    for k in range(n):
        world.step(sim.step_s, sim.physics_substeps)
        for j in range(n_moving):
            i = crews[(k + j) % len(crews)]
            x, y, heading = world.pose(i)
            c, s = math.cos(heading), math.sin(heading)
            query, frontal, _ = world.ray_query(i)
            for ux, uy, length, _ in rays.rays:
                query((x, y), (x + (c * ux - s * uy) * length, y + (s * ux + c * uy) * length),
                      frontal)
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
    floor = raw_floor(env.engine.case, rng)
    run_env(env, actions, 200)  # warm-up
    for _ in range(args.rounds):
        dt, a, m = run_env(env, actions, args.steps)
        env_s, agent_steps, moving = env_s + dt, agent_steps + a, moving + m
        floor_s += run_floor(floor, env, args.steps, m / args.steps)
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
