"""Quick start: simulate one floor with the priority heuristic (Eq. 9) and the scripted navigator.

    python examples/quickstart.py                  # the built-in precast floor, seed 0 (a few s)
    python examples/quickstart.py --env cmdp/TinyFloor-v1

Prints the makespan and each crew's idle and reaching steps. ``cmdp-simulate`` does the same
and writes charts and files; this is the loop it runs.
"""

import argparse

import pettingzoo

import cmdp_pymunk  # noqa: F401  (importing it registers the cmdp/ variants)
from agents.navigator import Navigator  # the scripted low level: walks each crew to its target
from cmdp_pymunk.report import crew_summary


def main(argv=None) -> float:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", default="cmdp/PrecastFloor-v1", help="a registered variant")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)

    env = pettingzoo.make("parallel", args.env, seed=args.seed)  # Eq. 9 picks the targets
    observations, infos = env.reset(seed=args.seed)
    navigator = Navigator()
    while env.agents:  # every crew stays an agent until the floor is built
        observations, rewards, terminations, truncations, infos = env.step(
            env.agent_actions(navigator, observations))
    print(f"{args.env} seed {args.seed}: makespan {env.makespan_s:,.0f} s")
    for crew, stats in crew_summary(env.engine).items():  # what summary.json holds per crew
        print(f"  {crew:6s} reaching steps {stats['reaching_steps']:6d}   idle steps "
              f"{sum(stats['idle_steps'].values()):6d}   walked {stats['distance_m']:7.0f} m")
    return env.makespan_s


if __name__ == "__main__":
    main()
