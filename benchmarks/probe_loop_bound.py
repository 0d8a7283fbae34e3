"""How much faster could the event floor's loop get by skipping passes over the crews? A bound.

    python benchmarks/probe_loop_bound.py [--seeds 1-30] [--rounds 3]

Issue 43 asks for the event floor at 20 ms a floor, about 2.4 x its speed when the issue was
written, and the profile is flat: per event a dozen passes over the seven crews, each a few per
cent. The route proposed for it is skipping the passes whose crews did not change (dirty
tracking). This probe measures what that route can give at most: it plays the same seeds on two
event floors of the built-in case (Eq. 9, the case's calibration, the CLI's stall guard), floor
by floor in turn in one process (CPU time), the second with the bookkeeping passes made free:

- the counters (``metrics.Counters.count``) and the advance's sums (``engine.Advance.add``);
- the event log's activity and position events (``Engine._log_activities``,
  ``Engine._log_positions``);
- R_e's terms (``reward.evaluation_reward_terms``) and the span's counted states
  (``motion.crew_states``).

None of them feeds the dynamics (the script checks that both floors give the same makespans),
so the free floor is what a perfect dirty tracking of them would leave: the table's rows and
their effects (Table 1, the pace draws), P_cons (Eq. 2) and the next event's time, the target
evaluation (Eq. 9), and the walks. It prints CPU ms a floor of each, round by round, and the
ratio of the medians. A bound, not a setting: the free floor writes no log and counts nothing.

First, untimed, what ends each span (each event) on those seeds: P_cons' next change (a task
ends, a load is full or runs out, a storage reaches its reorder point, the crane is done:
``construct.next_change_in``), a walk arriving, a row of Table 1 due in the next second, or the
rest (a re-evaluation due, a disruption, the stall guard, the time limit). Events are the
model's own: fewer of them means another model, not a faster loop.
"""

from __future__ import annotations

import argparse
import collections
import math
import statistics
import time

import cmdp_pymunk
from cmdp_pymunk import construct, engine, metrics, reward
from cmdp_pymunk.eventfloor import EventFloor, calibration_for
from cmdp_pymunk.eventfloor import floor as event_floor
from training.cli import seed_list
from training.runs.base import collect_less

# the bookkeeping passes, by (owner, name), and what each is made when free
_FREE = (
    (metrics.Counters, "count", lambda self, span: None),
    (engine.Advance, "add", lambda self, span: None),
    (engine.Engine, "_log_activities", lambda self: None),
    (engine.Engine, "_log_positions", lambda self: None),
    (reward, "evaluation_reward_terms", lambda site, weights: {}),
    (event_floor, "crew_states", lambda site: None),
)


class _Free:
    """The bookkeeping passes made free inside the block (restored on leaving it)."""

    def __enter__(self):
        self.kept = [(owner, name, getattr(owner, name)) for owner, name, _ in _FREE]
        for owner, name, free in _FREE:
            setattr(owner, name, free)

    def __exit__(self, *exc):
        for owner, name, kept in self.kept:
            setattr(owner, name, kept)


def play(floor: EventFloor, seeds: list[int]) -> tuple[float, list]:
    """CPU ms a floor over ``seeds``, and their makespans."""
    makespans = []
    start = time.process_time()
    for seed in seeds:
        floor.reset(seed)
        floor.run()
        makespans.append(floor.makespan_s)
    return (time.process_time() - start) / len(seeds) * 1000.0, makespans


def event_causes(floor: EventFloor, seeds: list[int]) -> dict[str, float]:
    """What ended each span on ``seeds``, per floor (the module doc's four causes)."""
    motion = floor.motion
    span_s = motion.span_s
    causes: collections.Counter = collections.Counter()

    def counted(engine_):
        k = span_s(engine_)
        site, now = engine_.site, engine_.site.time_s
        change = construct.next_change_in(site, engine_.positions, motion.invasion_of,
                                          engine_.lift_levels)
        if change < math.inf and max(1, math.ceil(change - 1e-9)) == k:
            causes["P_cons' next change"] += 1
        elif any(walk is not None and crew.moving and walk.arrival_s == now + k
                 for walk, crew in zip(motion.walks, site.crews, strict=True)):
            causes["a walk arrives"] += 1
        elif k == 1:
            causes["a row due in the next second"] += 1
        else:
            causes["the rest"] += 1
        return k

    motion.span_s = counted  # this floor's motion only, for these seeds
    try:
        for seed in seeds:
            floor.reset(seed)
            floor.run()
    finally:
        del motion.span_s
    return {cause: n / len(seeds) for cause, n in causes.most_common()}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--seeds", default="1-30", help="seeds played by both floors (e.g. 1-30)")
    p.add_argument("--rounds", type=int, default=3)
    args = p.parse_args(argv)
    seeds = seed_list(args.seeds)
    collect_less()  # as the workers of cmdp-simulate run
    case = cmdp_pymunk.load_case(None)
    floors = []
    for _ in range(2):
        floor = EventFloor(case, evaluator="priority", stall_s=3600.0,
                           calibration=calibration_for(case, None))
        floor.reset(0)
        floor.run()  # the case's paths planned (untimed)
        floors.append(floor)
    causes = event_causes(floors[0], seeds)
    print(f"events a floor, {sum(causes.values()):.0f}, by what ends the span: " +
          ", ".join(f"{cause} {n:.1f}" for cause, n in causes.items()), flush=True)
    rows = {"as shipped": [], "bookkeeping free": []}
    for r in range(args.rounds):
        ms, want = play(floors[0], seeds)
        rows["as shipped"].append(ms)
        with _Free():
            ms, got = play(floors[1], seeds)
        rows["bookkeeping free"].append(ms)
        if got != want:
            raise SystemExit("the free floor's makespans differ: a pass made free feeds the "
                             "dynamics; fix: drop it from _FREE")
        print(f"round {r}: as shipped {rows['as shipped'][-1]:.1f}, bookkeeping free "
              f"{rows['bookkeeping free'][-1]:.1f} CPU ms a floor", flush=True)
    shipped, free = (statistics.median(v) for v in rows.values())
    print(f"{len(seeds)} seeds x {args.rounds} rounds, medians: as shipped {shipped:.1f}, "
          f"bookkeeping free {free:.1f} CPU ms a floor: at most {shipped / free:.2f} x by "
          "skipping those passes")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
