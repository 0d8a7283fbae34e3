"""Playing a plan search's floors (``training.search.plan_search``): ``plan_job``, one plan on
one seed in a worker that keeps its last ``_KEEP`` plans' runners, and ``Floors``, every floor
played kept by (floor, plan, seed) in ``episodes.jsonl`` so that a resumed search plays none
twice.

Apart from the search because it is the one part that runs floors: it knows the backend and the
episode runner, and nothing of Optuna, the objectives or the outputs. ``plan_job`` is what the
backend sends to its workers, by this module's name.
"""

from __future__ import annotations

import hashlib
import json
from collections import OrderedDict
from pathlib import Path

from cmdp_pymunk.cases.model import Case

from ..runs.runner import EpisodeRunner
from ..whatif import played_row
from .plan_config import PlanConfig

_RUNNERS: OrderedDict[str, EpisodeRunner] = OrderedDict()
_KEEP = 16  # runners kept per worker process (a plan's engine is made again after that)


def plan_job(_runner, key: str, case_data: dict, runner_args: tuple, evaluator: str,
             seed: int) -> dict:
    """One floor of one plan on one seed (``training.whatif.played_row``: the makespan and
    what it cost), in a worker that keeps the runners of its last ``_KEEP`` plans."""
    runner = _RUNNERS.pop(key, None)
    if runner is None:
        from cmdp_pymunk.cases.load import case_from_dict

        runner = EpisodeRunner(case_from_dict(case_data, key), *runner_args)
    _RUNNERS[key] = runner
    while len(_RUNNERS) > _KEEP:
        _RUNNERS.popitem(last=False)
    row = played_row(runner, evaluator, "scripted", seed)
    return {k: row[k] for k in ("makespan_s", "finished", "crane_lifts", "cost",
                                "cost_crew_rates_x2", "stall_reason")}


class Floors:
    """Every floor played, kept by (floor, plan, seed) in ``episodes.jsonl`` (a line each, as
    it comes: a resumed run reads them back and plays none twice), and ``play`` for the ones
    not yet played, on the backend."""

    def __init__(self, out: Path, pool, bar, floors: dict[str, tuple], config: PlanConfig):
        self.path = out / "episodes.jsonl"
        self.pool, self.bar, self.floors, self.config = pool, bar, floors, config
        self.rows: dict[tuple[str, str, int], dict] = {}
        if self.path.is_file():
            for line in self.path.read_text(encoding="utf-8").splitlines():
                try:
                    r = json.loads(line)
                except json.JSONDecodeError:  # a line cut by a crash: played again
                    continue
                self.rows[(r["floor"], r["plan"], r["seed"])] = r
        self.played = 0

    def play(self, fidelity: str, wanted: list[tuple[str, Case, int]]) -> None:
        """Play the (plan label, case, seed) floors of ``wanted`` not yet kept."""
        todo, seen = [], set()
        for label, case, seed in wanted:
            if (label, seed) not in seen and (fidelity, label, seed) not in self.rows:
                todo.append((label, case, seed))
            seen.add((label, seed))
        counted = len(wanted) - len(todo)  # already kept: counted on the bar at once
        if counted:
            self.bar.update(counted)
        if not todo:
            return
        dumps: dict[str, tuple[str, dict]] = {}
        jobs = []
        for label, case, seed in todo:
            if label not in dumps:
                data = case.model_dump(mode="json")
                # a worker keeps runners by this key: the case's digest beside the plan's label,
                # so two searches in one process (of two cases) never share a runner
                digest = hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()
                dumps[label] = (f"{fidelity}:{label}:{digest[:16]}", data)
            jobs.append((*dumps[label],
                         (self.config.stall_s, None, False, None, *self.floors[fidelity]),
                         self.config.evaluator, seed))
        with self.path.open("a", encoding="utf-8") as log:
            for i, row in self.pool.as_completed(jobs):
                label, _, seed = todo[i]
                r = {"floor": fidelity, "plan": label, "seed": seed, **row}
                self.rows[(fidelity, label, seed)] = r
                log.write(json.dumps(r) + "\n")
                log.flush()
                self.bar.update(1)
                self.played += 1

    def of(self, fidelity: str, label: str, seeds) -> list[dict]:
        return [self.rows[(fidelity, label, s)] for s in seeds
                if (fidelity, label, s) in self.rows]
