"""A random agent: every crew takes a random action from its action space.

    python examples/random_agent.py                      # cmdp/TinyFloor-v1, 2,000 steps
    python examples/random_agent.py --env cmdp/PrecastFloor-stage1-v1 --steps 500

The observation is ``Box(119)`` per crew (rays, Eq. 3; velocity; target memory), the action
``MultiDiscrete([4, 3, 3])`` (forward, lateral, turn; Eq. 1), the reward the reaching reward
(Eqs. 6-7). Random walking rarely reaches a target, so the floor is not built: the episode runs
until ``--steps`` or the variant's time limit, and the summed reward shows how a random
policy scores (the baseline any trained reaching policy should beat).
"""

import argparse

import numpy as np
import pettingzoo

import cmdp_pymunk  # noqa: F401  (registers the cmdp/ variants)


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", default="cmdp/TinyFloor-v1", help="a registered variant")
    p.add_argument("--steps", type=int, default=2000, help="env steps at most")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)

    env = pettingzoo.make("parallel", args.env, seed=args.seed)
    observations, infos = env.reset(seed=args.seed)
    for agent in env.agents:  # seed every action space once, for a repeatable run
        env.action_space(agent).seed(args.seed + env.agents.index(agent))
    returns = dict.fromkeys(env.agents, 0.0)
    steps = 0
    while env.agents and steps < args.steps:
        actions = {a: env.action_space(a).sample() for a in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)
        for agent, reward in rewards.items():
            returns[agent] += reward
        steps += 1
    site = env.engine.site  # the floor's state is the engine's
    print(f"{args.env}: {steps} steps, {site.tasks_ended}/{len(site.tasks)} tasks ended, "
          f"simulated {site.time_s:,.0f} s")
    for agent, ret in returns.items():
        print(f"  {agent:6s} return {ret:9.2f}")
    print(f"  mean return {np.mean(list(returns.values())):.2f}")
    return returns


if __name__ == "__main__":
    main()
