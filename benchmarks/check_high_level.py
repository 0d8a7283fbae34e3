"""Does one model with a lift head play the schedule of a target model plus a logistics role
(issue 42 item 6)? Both runs on the same seeds and floor, event log against event log.

    PYTHONPATH=. python benchmarks/check_high_level.py --seeds 140-145 --floor pymunk \\
        --one models/stage2_high_level.zip \\
        --pair models/stage2_evaluator.zip:learned=models/logistics_learned.json

``--one MODEL.zip`` plays alone (its lift head answers the floor's lift questions, as
``cmdp-simulate --evaluator MODEL.zip`` gives it); ``--pair EVALUATOR:ROLE`` is a run of
``bench_learned_logistics`` (its ``=`` for a role's ``:``). Prints each seed's makespans,
events and whether the logs are the same; exits 1 if any seed differs. The scripted navigator;
one process.
"""

from __future__ import annotations

import argparse
import sys
import time

import cmdp_pymunk
from cmdp_pymunk import add_version_flag
from training.cli import seed_list


def event_log(case, evaluator: str, logistics: str, seed: int, floor: str):
    """One seed's floor: (makespan, the event log as tuples, CPU seconds)."""
    from agents.specs import evaluator_from_spec, make_navigator
    from cmdp_pymunk.eventfloor import calibration_for
    from cmdp_pymunk.rollout import run_episode
    from training.runs.runner import make_engine

    start = time.process_time()
    engine = make_engine(case, evaluator_from_spec(evaluator), "scripted", fidelity=floor,
                         calibration=calibration_for(case) if floor == "event" else None,
                         logistics=logistics)
    episode = run_episode(engine, make_navigator("scripted", engine, False), seed, 3600.0,
                          progress=False)
    events = [(e.time_s, e.kind, e.crew, e.subject, e.detail) for e in engine.log.events]
    return episode.makespan_s, events, time.process_time() - start


def main(argv=None) -> int:
    from benchmarks.bench_learned_logistics import logistics_spec, split_run

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_version_flag(p)
    p.add_argument("--seeds", default="140-145")
    p.add_argument("--floor", choices=("pymunk", "event"), default="pymunk")
    p.add_argument("--one", default="models/stage2_high_level.zip",
                   help="a model with a lift head, played alone")
    p.add_argument("--pair", default="models/stage2_evaluator.zip:learned="
                   "models/logistics_learned.json", help="EVALUATOR:ROLE to compare with")
    a = p.parse_args(sys.argv[1:] if argv is None else argv)
    case = cmdp_pymunk.load_case(None)
    evaluator, role = split_run(a.pair)
    differ = 0
    for seed in seed_list(a.seeds):
        one = event_log(case, a.one, "case", seed, a.floor)
        pair = event_log(case, evaluator, logistics_spec(role), seed, a.floor)
        same = one[:2] == pair[:2]
        differ += not same
        print(f"seed {seed} ({a.floor}): one model {one[0]} s, pair {pair[0]} s, "
              f"{len(one[1])}/{len(pair[1])} events, {'same' if same else 'DIFFERENT'} "
              f"({one[2]:.1f} + {pair[2]:.1f} s CPU)", flush=True)
    return 1 if differ else 0


if __name__ == "__main__":
    raise SystemExit(main())
