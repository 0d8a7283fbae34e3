"""Plot the Gantt charts of one simulated floor from Python (Figs. 9 and 10).

    python examples/gantt.py                        # the tiny floor -> out/examples/gantt_*.png
    python examples/gantt.py --env cmdp/PrecastFloor-v1 --out out/gantt

Every chart is drawn from the env's event log alone (``env.log.events``, what ``events.csv``
holds), so the same calls redraw a saved run: ``cmdp_pymunk.events.read_csv(path)``.
"""

import argparse
from pathlib import Path

import pettingzoo

import cmdp_pymunk  # noqa: F401  (registers the cmdp/ variants)
from agents.navigator import Navigator
from cmdp_pymunk.schedule import task_bars
from media.gantt import gantt_agents, gantt_tasks


def main(argv=None) -> list[Path]:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", default="cmdp/TinyFloor-v1", help="a registered variant")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=Path("out/examples"))
    args = p.parse_args(argv)

    env = pettingzoo.make("parallel", args.env, seed=args.seed)
    observations, _ = env.reset(seed=args.seed)
    navigator = Navigator()
    while env.agents:
        observations, *_ = env.step(env.agent_actions(navigator, observations))

    events = env.log.events  # the append-only event log
    for bar in task_bars(events)[:5]:  # the schedule as data: one bar per task
        print(bar)
    paths = [gantt_agents(events, args.out / "gantt_agents.png"),            # Fig. 9
             gantt_tasks(events, args.out / "gantt_tasks.png", env.case)]    # Fig. 10
    print("wrote", *paths)
    return paths


if __name__ == "__main__":
    main()
