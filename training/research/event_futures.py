"""How many futures does a trustworthy lookahead label need? Measured on the event floor.

    python -m training.research.event_futures [--seeds 0-1] [--futures 32] [--every 3]
                                              [--candidates 3] [--out FILE]

On Eq. 9's pymunk floors of the seeds, at every ``every``-th decision with two or more
candidates (a task scope), an event floor is built from the pymunk floor's state
(``engine.clone(motion=WalkMotion(...))``, the case's calibration) and each of Eq. 9's
``candidates`` best targets is played to the end on ``futures`` sampled futures, the same for
every candidate (paired, as the lookahead's). Per decision and future, each candidate's
makespan minus the first's (Eq. 9's choice) is split as ``training.research.label_noise``
splits a label run's: what every future shares (``signal_sd_s``: the square root of the
covariance of two futures' differences) and what each future adds (``noise_sd_s``); and how
often the best candidate on the mean of k futures agrees with the best on the mean of the other
half, for k = 1, 2, 4, ... The pymunk floor goes on with Eq. 9's values (the states are Eq.
9's). Prints the table and the CPU seconds a branch costs; writes every makespan to ``--out``
(JSON).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import cmdp_pymunk
from agents.navigator import Navigator
from agents.priority import PriorityEvaluator
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.evaluate import Evaluator
from cmdp_pymunk.eventfloor import WalkMotion, calibration_for
from cmdp_pymunk.rollout import run_episode
from cmdp_pymunk.state import ScopeKind
from training.cli import seed_list

SCENARIO_BASE = 7_000_000  # far from the lookahead's and label_noise's keys


class FutureProbe(Evaluator):
    """Eq. 9 that, at every ``every``-th decision of a task scope, plays its best candidates
    on event floors in ``futures`` sampled futures and keeps the makespans."""

    between_seconds = True  # it branches the floor

    def __init__(self, calibration, futures: int, every: int, candidates: int, seed: int):
        self.base = PriorityEvaluator()
        self.calibration, self.futures, self.every = calibration, futures, every
        self.candidates, self.seed = candidates, seed
        self.decisions = 0
        self.rows: list[dict] = []
        self.cpu_s = 0.0
        self.branches = 0

    def values_for(self, engine, i: int) -> dict[int, float]:
        values = self.base.values_for(engine, i)
        crew = engine.site.crews[i]
        order = sorted(values, key=lambda t: (-values[t], t))[:self.candidates]
        if crew.scope_kind != ScopeKind.TASKS or len(order) < 2:
            return values
        self.decisions += 1
        if self.decisions % self.every:
            return values
        start = time.process_time()
        floor = engine.clone(keep_log=False, motion=WalkMotion(self.calibration))
        floor.evaluator = self.base
        makespans = []
        for k in range(self.futures):
            scenario = SCENARIO_BASE + 100_003 * k + 1_009 * self.seed + self.decisions
            row = []
            for target in order:
                branch = floor.clone(scenario, keep_log=False)
                promoted = dict(values)
                best = order[0]
                promoted[best], promoted[target] = values[target], values[best]
                branch.set_target_values(i, promoted)
                for j in list(branch.pending):
                    branch.set_target_values(j, self.base.values_for(branch, j))
                branch.run()
                row.append(branch.makespan_s or branch.site.time_s + 100_000.0)
                self.branches += 1
            makespans.append(row)
        self.cpu_s += time.process_time() - start
        self.rows.append({"seed": self.seed, "time_s": engine.site.time_s, "crew": i,
                          "candidates": order, "makespans_s": makespans})
        return values


def split(rows: list[dict]) -> dict:
    """Signal and noise of the candidates' differences to the first (see the module doc)."""
    diffs = [np.array(r["makespans_s"])[:, 1:] - np.array(r["makespans_s"])[:, :1]
             for r in rows]  # futures x (candidates - 1) per decision
    a = np.concatenate([d[0::2][: len(d) // 2].ravel() for d in diffs])
    b = np.concatenate([d[1::2][: len(d) // 2].ravel() for d in diffs])
    signal = float(np.sqrt(max(0.0, np.cov(a, b)[0, 1])))
    noise = float(np.std(a - b) / np.sqrt(2))
    agree = {}
    k = 1
    futures = min(len(r["makespans_s"]) for r in rows)
    while 2 * k <= futures:
        same = [int(np.argmin(np.mean(np.array(r["makespans_s"])[:k], axis=0)) ==
                    np.argmin(np.mean(np.array(r["makespans_s"])[k:2 * k], axis=0)))
                for r in rows]
        agree[k] = float(np.mean(same))
        k *= 2
    return {"signal_sd_s": signal, "noise_sd_s": noise, "agreement_by_futures": agree,
            "decisions": len(rows)}


def main(argv: list[str] | None = None) -> None:

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--seeds", type=seed_list, default=[0, 1])
    p.add_argument("--futures", type=int, default=32)
    p.add_argument("--every", type=int, default=3)
    p.add_argument("--candidates", type=int, default=3)
    p.add_argument("--out", type=Path, default=Path("runs/event_futures.json"))
    args = p.parse_args(argv)
    case = cmdp_pymunk.load_case()
    calibration = calibration_for(case)
    rows, cpu, branches = [], 0.0, 0
    for seed in args.seeds:
        probe = FutureProbe(calibration, args.futures, args.every, args.candidates, seed)

        engine = Engine(case, evaluator=probe, park_idle=True)
        run_episode(engine, Navigator(), seed, 3600.0, progress=False)
        rows += probe.rows
        cpu += probe.cpu_s
        branches += probe.branches
        print(f"seed {seed}: {len(probe.rows)} decisions probed, {probe.branches} branches, "
              f"{probe.cpu_s:.0f} CPU s", flush=True)
    result = split(rows)
    result["cpu_s_per_branch"] = cpu / max(1, branches)
    print(json.dumps(result, indent=1))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"summary": result, "rows": rows}), encoding="utf-8")


if __name__ == "__main__":
    main()
