"""A fingerprint of what the event floor computes, to hold its results fixed while it is sped up.

    python benchmarks/event_floor_reference.py > /tmp/ref.txt   # before a change
    python benchmarks/event_floor_reference.py | diff /tmp/ref.txt -   # after it: no output

Runs the event floor (each case's calibration, ``calibration_for``, the stall guard of the
CLI) on seeds 0-9 with the evaluators priority, nearest and the searched student rule on the
built-in, the disrupted and the tiny case, and prints per floor a hash of its event log (time,
kind, crew, subject and detail of every event), its makespan, events run and a hash of every
crew's ``stats``. Then the paths that branch and feed the floor: position events (trajectories),
values from outside (``pending``), clones continued (the floor's own future and a sampled
one) and clones onto the walk motion (``clone(motion=WalkMotion(...))``: from an event floor,
and from the pymunk floor on the tiny case). Speed is not measured here
(``bench_event_floor.py``): any line that changes means a result changed.
"""

from __future__ import annotations

import dataclasses
import hashlib
import sys

import cmdp_pymunk
from agents.navigator import Navigator
from agents.specs import evaluator_from_spec
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.evaluate import PriorityEvaluator
from cmdp_pymunk.eventfloor import EventFloor, WalkMotion, calibration_for

SEEDS = range(10)
EVALUATORS = ("priority", "nearest", "student:models/searched_rule.json")
CASES = {"builtin": cmdp_pymunk.BUILTIN_CASE, "disrupted": cmdp_pymunk.DISRUPTED_CASE,
         "tiny": cmdp_pymunk.TINY_CASE}
STALL_S = 3600.0


def _hash(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def fingerprint(floor: EventFloor, total=None) -> str:
    """The floor's log, makespan, events run, crews' stats (and R_e's terms summed over the
    run, ``total``) as one line."""
    log = "\n".join(repr(tuple(e)) for e in floor.log.events)
    stats = repr([(c.id, c.status.name, dataclasses.astuple(c.stats)) for c in floor.site.crews])
    return (f"t={floor.site.time_s!r} makespan={floor.makespan_s!r} "
            f"events={floor.spans_run} log={len(floor.log.events)}:{_hash(log)} "
            f"stats={_hash(stats)} stalled={floor.stalled!r}"
            + (f" terms={_hash(repr(total.terms))}" if total is not None else ""))


def main() -> int:
    out = sys.stdout
    for name, path in CASES.items():
        case = cmdp_pymunk.load_case(path)
        calibration = calibration_for(case)
        for spec in EVALUATORS:
            floor = EventFloor(case, evaluator=evaluator_from_spec(spec), stall_s=STALL_S,
                               calibration=calibration)
            for seed in SEEDS:
                floor.reset(seed)
                total = floor.run()
                out.write(f"{name} {spec} seed {seed}: {fingerprint(floor, total)}\n")
        # trajectories: position events at each event
        floor = EventFloor(case, evaluator="priority", stall_s=STALL_S, calibration=calibration,
                           position_log_every_s=1.0)
        for seed in range(3):
            floor.reset(seed)
            floor.run()
            out.write(f"{name} positions seed {seed}: {fingerprint(floor)}\n")
        # values from outside: the floor stops at every crew that needs them
        floor = EventFloor(case, evaluator=None, stall_s=STALL_S, calibration=calibration)
        rule = PriorityEvaluator()
        for seed in range(3):
            floor.reset(seed)
            stops, parts = 0, []
            while True:
                while floor.pending:
                    i = floor.pending[0]
                    floor.set_target_values(i, rule.values_for(floor, i))
                stops += 1
                part = floor.advance(None, until=lambda: False)
                parts.append((part.elapsed, tuple(part.terms.values()), floor.metrics.window))
                if part.terminated or part.truncated:
                    break
            out.write(f"{name} pending seed {seed}: stops={stops} parts={_hash(repr(parts))} "
                      f"{fingerprint(floor)}\n")
        # a clone at the first task's end, and a floor built from it, each run to the end
        floor = EventFloor(case, evaluator="priority", stall_s=STALL_S, calibration=calibration)
        for seed in range(3):
            floor.reset(seed)
            terms = []
            while floor.site.tasks_ended < min(3, len(floor.site.tasks) - 1):
                part = floor.advance(None)
                terms.append((part.elapsed, tuple(part.terms.values()), floor.metrics.window))
            branch = floor.clone()
            sampled = floor.clone(scenario=seed + 1)  # another future: paces, disruptions
            rebuilt = floor.clone(motion=WalkMotion(calibration))
            for f in (floor, branch, sampled, rebuilt):
                f.run()
            out.write(f"{name} branch seed {seed}: terms={_hash(repr(terms))} "
                      f"original {fingerprint(floor)} clone {fingerprint(branch)} "
                      f"scenario {fingerprint(sampled)} from_engine {fingerprint(rebuilt)}\n")
    # from the pymunk floor at a decision (the lookahead's way), on the tiny case
    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    for seed in range(2):
        engine = Engine(case, evaluator="priority", park_idle=True)
        navigator = Navigator()
        engine.reset(seed)
        navigator.reset(seed)
        while engine.site.tasks_ended == 0:
            engine.advance(navigator.actions(engine, None), until=engine.decision_due)
        floor = engine.clone(motion=WalkMotion(calibration_for(case)))
        floor.run()
        out.write(f"tiny from pymunk seed {seed}: {fingerprint(floor)}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
