"""Task priorities as a target evaluator: the GA's genes (section 5.3) and the CP-SAT plan.

One priority per task of the case (section 5.3, its reference [57]: GA genes are task
priorities). A crew whose scope holds task targets prefers the target of its highest-priority
task; ``distance_weight`` adds Eq. 9's distance term, so that with equal priorities the nearer
target wins:

    V' = p_task + w * (1 - d / d_max)

or, with ``base = "priority"``, on top of the priority heuristic (Eq. 9's V', which already
holds distance, successors and space conflicts):

    V' = V'_Eq9 + p_task

so that equal priorities rank the targets exactly as the heuristic does, and the GA searches
for the tasks to move up or down from there.

mapped onto [0.5, 1] over the scope by ``as_target_values`` (Eq. 3 reserves 0 for objects
outside the scope). Storages and the outlet have no task: nearest first.

A priority file is a small JSON object::

    {"format": "cmdp-task-priorities/1", "case": "precast-floor", "source": "ga",
     "distance_weight": 0.5, "base": "none", "priorities": {"JC-P01": 0.73, ...}}

``cmdp-simulate --evaluator ga:PATH`` (``agents.specs``) loads one; ``bind(env)`` checks that
it names every task of the env's case and nothing else.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

from cmdp_pymunk.evaluate import PriorityEvaluator, Rule, as_target_values
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.jsonfile import read_json, require_entry

FORMAT = "cmdp-task-priorities/1"
BASES = ("none", "priority")


def task_priority_value(priority: float, distance: float, max_distance: float,
                        distance_weight: float) -> float:
    """V' = p + w * (1 - d / d_max): the task's priority plus Eq. 9's distance term (0 when
    d_max is 0)."""
    closeness = 1.0 - distance / max_distance if max_distance > 0 else 1.0
    return priority + distance_weight * closeness


class TaskPriorityEvaluator(Rule):
    """V_Tar from one priority per task id (a GA individual or a replayed plan)."""

    def __init__(self, priorities: Mapping[str, float], distance_weight: float = 0.0,
                 source: str = "<priorities>", base: str = "none"):
        if base not in BASES:
            raise ValueError(f"{source}: base {base!r} is not one of {', '.join(BASES)}")
        self.priorities = dict(priorities)
        self.distance_weight = float(distance_weight)
        self.source = source
        self.base = base
        self._heuristic = None
        if base == "priority":
            self._heuristic = PriorityEvaluator()

    @classmethod
    def from_genes(cls, task_ids: Sequence[str], genes: Sequence[float],
                   distance_weight: float = 0.0, base: str = "none") -> TaskPriorityEvaluator:
        """Genes in the case's task order (``case.tasks``)."""
        if len(task_ids) != len(genes):
            raise ValueError(f"{len(genes)} genes for {len(task_ids)} tasks")
        return cls(dict(zip(task_ids, map(float, genes), strict=True)), distance_weight,
                   "<genes>", base)

    def check_case(self, case) -> None:
        """ValueError naming the file, the entries and the fix unless the priorities cover
        exactly the case's tasks."""
        ids = [t.id for t in case.tasks]
        missing = [t for t in ids if t not in self.priorities]
        unknown = sorted(set(self.priorities) - set(ids))
        problems = []
        if missing:
            problems.append(f"no priority for task(s) {', '.join(missing[:5])}"
                            + (f" and {len(missing) - 5} more" if len(missing) > 5 else ""))
        if unknown:
            problems.append(f"unknown task(s) {', '.join(unknown[:5])}"
                            + (f" and {len(unknown) - 5} more" if len(unknown) > 5 else ""))
        if problems:
            raise ValueError(f"{self.source}: {'; '.join(problems)} for case "
                             f"{case.case.name!r}; fix: give one priority per task id of the "
                             "case (make the file for this case, e.g. with cmdp-ga)")

    def prepare(self, case) -> None:
        self.check_case(case)

    def target_values(self, crew, site, position):
        dist = {t: math.dist(position, site.target_points[t]) for t in crew.scope}
        d_max = max(dist.values(), default=0.0)
        if self._heuristic is not None and any(task >= 0 for task in crew.scope.values()):
            base = self._heuristic.priorities(crew, site, position)
            scores = {t: base[t] + (self.priorities[site.tasks[task].id] if task >= 0 else 0.0)
                      for t, task in crew.scope.items()}
        elif any(task >= 0 for task in crew.scope.values()):
            scores = {t: task_priority_value(
                self.priorities[site.tasks[task].id] if task >= 0 else 0.0, dist[t], d_max,
                self.distance_weight) for t, task in crew.scope.items()}
        else:  # storages or the outlet: nearest first
            scores = {t: task_priority_value(0.0, d, d_max, 1.0) for t, d in dist.items()}
        return as_target_values(scores)


def save_priorities(path: str | Path, case, priorities: Mapping[str, float],
                    distance_weight: float, source: str, base: str = "none",
                    **extra) -> Path:
    """Write a priority file (atomically); ``extra`` keys (how it was made) go in as they are."""
    data = {"format": FORMAT, "case": case.case.name, "source": source,
            "distance_weight": distance_weight, "base": base,
            "priorities": {t.id: round(float(priorities[t.id]), 6) for t in case.tasks}}
    data.update(extra)
    path = Path(path)
    write_atomic(path, json.dumps(data, indent=1) + "\n")
    return path


def load_priorities(path: str | Path) -> TaskPriorityEvaluator:
    """A ``TaskPriorityEvaluator`` from a priority file; ValueError naming the file, the entry
    and the fix for anything wrong."""
    path = Path(path)
    fix = "give a file written by cmdp-ga or cmdp-evaluate"
    data = read_json(path, "priority file", fix)
    require_entry(data, path, "format", FORMAT, fix)
    priorities = data.get("priorities")
    if not isinstance(priorities, dict) or not priorities:
        raise ValueError(f"{path}: \"priorities\" must be an object of task id -> number")
    bad = [k for k, v in priorities.items()
           if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)]
    if bad:
        raise ValueError(f"{path}: priorities[{bad[0]!r}] is {priorities[bad[0]]!r}; fix: give "
                         "a finite number for every task")
    weight = data.get("distance_weight", 0.0)
    if isinstance(weight, bool) or not isinstance(weight, (int, float)) \
            or not math.isfinite(weight) or weight < 0:
        raise ValueError(f"{path}: \"distance_weight\" is {weight!r}; fix: give a number >= 0")
    base = data.get("base", "none")
    if base not in BASES:
        raise ValueError(f"{path}: \"base\" is {base!r}; fix: give one of {', '.join(BASES)}")
    return TaskPriorityEvaluator(priorities, weight, str(path), base)
