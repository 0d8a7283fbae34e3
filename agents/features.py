"""What a target evaluator can see of each candidate beyond Eq. 9's own terms.

Per candidate target of a crew's task scope: Eq. 9's three ratios (successors, distance,
space conflicts), and what the rule cannot see (issue 17, item 4): the critical-path tail
behind the task (a backward pass over expected durations), the work it unlocks for the
bottleneck crew type (the type with the most expected work per crew), the queued tasks of
*other* crew types its area would block, the successors it makes executable at once, whether
a crew of the same type stands nearer to it, and the crews and task areas around it.

``FloorFacts`` holds what depends on the case only (computed once per case);
``candidate_features`` reads the state at a decision. Features are scaled to about [0, 1].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cmdp_pymunk.bounds import expected_duration_s
from cmdp_pymunk.state import CrewStatus, Pool

FEATURE_NAMES = ("successors", "nearness", "conflicts", "tail", "unlocks_bottleneck",
                 "blocks_other_types", "unlocks_now", "teammate_nearer", "crowding",
                 "areas_near", "rank1")
NEAR_M = 4.0  # "near" a target: other crews and task areas within this distance


@dataclass
class FloorFacts:
    """Case-only facts: expected duration and critical-path tail per task (s), the
    bottleneck crew type, and each task's expected bottleneck work among its successors."""

    duration_s: np.ndarray
    tail_s: np.ndarray
    bottleneck: str
    unlock_s: np.ndarray

    @classmethod
    def of(cls, site) -> FloorFacts:
        case = site.case
        tasks = site.tasks
        duration = np.array([expected_duration_s(case, case.tasks[t.index]) for t in tasks])
        tail = np.zeros(len(tasks))
        for t in reversed(_topological(tasks)):  # successors first
            tail[t] = duration[t] + max((tail[s] for s in tasks[t].successors), default=0.0)
        crews = {}
        for crew in site.crews:
            crews[crew.type] = crews.get(crew.type, 0) + 1
        work = {}
        for t in tasks:
            work[t.crew_type] = work.get(t.crew_type, 0.0) + duration[t.index]
        bottleneck = max(work, key=lambda ct: (work[ct] / max(1, crews.get(ct, 0)), ct))
        unlock = np.array([sum(duration[s] for s in t.successors
                               if tasks[s].crew_type == bottleneck) for t in tasks])
        return cls(duration, tail, bottleneck, unlock)


def _topological(tasks) -> list[int]:
    indegree = [len(t.predecessors) for t in tasks]
    order = [t.index for t in tasks if not t.predecessors]
    for t in order:  # grows while it is read
        for s in tasks[t].successors:
            indegree[s] -= 1
            if indegree[s] == 0:
                order.append(s)
    return order


def _rect_distance(rect, xy) -> float:
    x0, y0, x1, y1 = rect
    return math.hypot(max(x0 - xy[0], 0.0, xy[0] - x1), max(y0 - xy[1], 0.0, xy[1] - y1))


def candidate_features(facts: FloorFacts, crew, site, position, targets: list[int],
                       priorities: dict[int, float], positions=None) -> np.ndarray:
    """One row of ``FEATURE_NAMES`` per target in ``targets`` (task targets of the scope);
    ``positions``: every crew's (x, y), for the features about other crews (None: none)."""

    def position_of(c):
        return positions[c.index] if positions is not None else (math.inf, math.inf)

    rows = []
    tasks = [site.tasks[crew.scope[t]] for t in targets]
    dist = [math.dist(position, site.target_points[t]) for t in targets]
    suc = [task.all_successors for task in tasks]
    spa = [sum(site.tasks[o].pool == Pool.QUEUE for o in task.conflicts) for task in tasks]
    other = [sum(site.tasks[o].pool == Pool.QUEUE and site.tasks[o].crew_type != crew.type
                 for o in task.conflicts) for task in tasks]
    tail = [facts.tail_s[task.index] for task in tasks]
    unlock = [facts.unlock_s[task.index] for task in tasks]
    now = [sum(all(site.tasks[p].pool == Pool.END for p in site.tasks[s].predecessors
                   if p != task.index) for s in task.successors) for task in tasks]
    others = [c for c in site.crews if c.index != crew.index and c.status != CrewStatus.LEFT]
    xy = [site.target_xy[t] for t in targets]
    pos = {c.index: position_of(c) for c in others}
    teammate = [float(any(c.type == crew.type and math.dist(pos[c.index], xy[k]) < dist[k]
                          for c in others)) for k in range(len(targets))]
    crowd = [sum(math.dist(pos[c.index], xy[k]) < NEAR_M for c in others)
             for k in range(len(targets))]
    areas = [sum(_rect_distance(site.tasks[a].area, xy[k]) < NEAR_M for a in site.active_areas)
             for k in range(len(targets))]
    best = max(targets, key=lambda t: (priorities[t], -t))

    def ratio(x, xs):
        top = max(xs)
        return x / top if top > 0 else 0.0

    for k, target in enumerate(targets):
        rows.append((ratio(suc[k], suc), 1.0 - ratio(dist[k], dist), ratio(spa[k], spa),
                     ratio(tail[k], tail), ratio(unlock[k], unlock), ratio(other[k], other),
                     ratio(now[k], now), teammate[k], crowd[k] / max(1, len(others)),
                     ratio(areas[k], areas), 1.0 if target == best else 0.0))
    return np.array(rows, dtype=np.float64)
