"""What a target evaluator can see of each candidate beyond Eq. 9's own terms.

Per candidate target of a crew's task scope: Eq. 9's three ratios (successors, distance,
space conflicts), and what the rule cannot see (issue 17, item 4): the critical-path tail
behind the task (a backward pass over expected durations), the work it unlocks for the
bottleneck crew type (the type with the most expected work per crew), the queued tasks of
*other* crew types its area would block, the successors it makes executable at once, whether
a crew of the same type stands nearer to it, and the crews and task areas around it.

The binding features (issue 32, item 2) look at the crew type that binds the floor: the one
with the most *expected* work per crew, its tasks' durations under the pace law (Jensen: the
mean of work / efficiency, not work / mean efficiency) plus material loading
(``bounds.expected_work_by_crew_type``); on the built-in floor the reinforcing crews (RC
21,037 s a crew against FC 18,339 s), where the mean pace names formwork. Per candidate: the
binding work among its direct successors (``unlocks_binding``; the HI tasks release 2-4 R
tasks each), the part of it released at once when the candidate ends
(``releases_binding_now``), the queued binding tasks its area would block while it runs
(``blocks_binding``), and binding work released at once while a binding crew stands idle
(``feeds_idle_binding``). The crane queue is not one: a crew's candidates are all of its
own type, so all or none of them need the crane and the queue never tells them apart
(measured: 0 of 156 decisions on the event floor, seeds 0-2).

``unlocks_bottleneck`` keeps its first definition (the bottleneck at the mean pace,
``FloorFacts.mean_pace_bottleneck``: formwork on the built-in floor, so it counts an R task's
one F successor and never separates candidates) because the committed
``models/searched_rule.json`` and ``models/stage2_desired_position.zip`` were made with it.
``FEATURE_NAMES`` are the first eleven, the stage-2 model's columns; ``ALL_FEATURES`` adds
``BINDING_FEATURES``, for students and rule searches that name them.

``FloorFacts`` holds what depends on the case only (computed once per case);
``candidate_features`` reads the state at a decision. Features are scaled to about [0, 1].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cmdp_pymunk.bounds import (
    expected_duration_s,
    expected_task_duration_s,
    expected_work_by_crew_type,
    loading_s,
)
from cmdp_pymunk.state import CrewStatus, Pool

FEATURE_NAMES = ("successors", "nearness", "conflicts", "tail", "unlocks_bottleneck",
                 "blocks_other_types", "unlocks_now", "teammate_nearer", "crowding",
                 "areas_near", "rank1")
BINDING_FEATURES = ("unlocks_binding", "releases_binding_now", "blocks_binding",
                    "feeds_idle_binding")
ALL_FEATURES = FEATURE_NAMES + BINDING_FEATURES
NEAR_M = 4.0  # "near" a target: other crews and task areas within this distance


@dataclass
class FloorFacts:
    """Case-only facts: per task the mean-pace duration and critical-path tail (s) and the
    expected duration with loading (``expected_s``); the
    binding crew type (``bottleneck``: the most expected work per crew, Jensen and loading)
    and per task the expected work (s) it unlocks for it among its direct successors
    (``binding_unlock_s``); and the first definition kept for the committed models (module
    doc): ``mean_pace_bottleneck`` and ``unlock_s``."""

    duration_s: np.ndarray
    tail_s: np.ndarray
    expected_s: np.ndarray  # per task: expected duration under the pace law plus loading
    bottleneck: str
    binding_unlock_s: np.ndarray
    mean_pace_bottleneck: str
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
        mean_pace = max(work, key=lambda ct: (work[ct] / max(1, crews.get(ct, 0)), ct))
        per_crew = expected_work_by_crew_type(case)
        binding = max(per_crew, key=lambda ct: (per_crew[ct], ct))
        expected = np.array([expected_task_duration_s(case, t) + loading_s(case, t)
                             for t in case.tasks])
        return cls(duration, tail, expected, binding, unlocked_work(tasks, binding, expected),
                   mean_pace, unlocked_work(tasks, mean_pace, duration))


def unlocked_work(tasks, crew_type: str, seconds) -> np.ndarray:
    """Per task, the seconds of ``crew_type``'s work among its direct successors."""
    return np.array([sum(seconds[s] for s in t.successors if tasks[s].crew_type == crew_type)
                     for t in tasks], dtype=np.float64)


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
                       priorities: dict[int, float], positions=None,
                       names: tuple[str, ...] = FEATURE_NAMES) -> np.ndarray:
    """One row per target in ``targets`` (task targets of the scope), a column per feature
    in ``names`` (``FEATURE_NAMES`` by default, any of ``ALL_FEATURES``); ``positions``:
    every crew's (x, y), for the features about other crews (None: none)."""
    rows = _first_features(facts, crew, site, position, targets, priorities, positions)
    if names == FEATURE_NAMES:
        return rows
    both = np.hstack([rows, binding_features(facts, site, crew, targets)])
    return both[:, [ALL_FEATURES.index(n) for n in names]]


def binding_features(facts: FloorFacts, site, crew, targets: list[int]) -> np.ndarray:
    """``BINDING_FEATURES`` per target (module doc), each a ratio to the largest among the
    targets (0 where all are 0)."""
    tasks = [site.tasks[crew.scope[t]] for t in targets]
    binding = facts.bottleneck
    unlock = [facts.binding_unlock_s[t.index] for t in tasks]
    now = [_released_binding_s(site, facts, t) for t in tasks]
    blocks = [sum(site.tasks[o].pool == Pool.QUEUE and site.tasks[o].crew_type == binding
                  for o in t.conflicts) for t in tasks]
    idle = any(c.type == binding and c.status == CrewStatus.REACHING and not c.scope
               and not c.absent for c in site.crews)
    return np.array([(_ratio(unlock[k], unlock), _ratio(now[k], now),
                      _ratio(blocks[k], blocks),
                      _ratio(now[k], now) if idle else 0.0) for k in range(len(tasks))],
                    dtype=np.float64).reshape(len(tasks), len(BINDING_FEATURES))


def _released_binding_s(site, facts: FloorFacts, task) -> float:
    """Binding-type work (expected, with loading) among ``task``'s successors whose other
    predecessors have all ended: released the moment ``task`` ends."""
    return sum(facts.expected_s[s] for s in task.successors
               if site.tasks[s].crew_type == facts.bottleneck
               and all(site.tasks[p].pool == Pool.END for p in site.tasks[s].predecessors
                       if p != task.index))


def _ratio(x: float, xs: list[float]) -> float:
    top = max(xs)
    return x / top if top > 0 else 0.0


def _first_features(facts: FloorFacts, crew, site, position, targets: list[int],
                    priorities: dict[int, float], positions) -> np.ndarray:
    """``FEATURE_NAMES`` per target (the module doc)."""

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

    ratio = _ratio

    for k, target in enumerate(targets):
        rows.append((ratio(suc[k], suc), 1.0 - ratio(dist[k], dist), ratio(spa[k], spa),
                     ratio(tail[k], tail), ratio(unlock[k], unlock), ratio(other[k], other),
                     ratio(now[k], now), teammate[k], crowd[k] / max(1, len(others)),
                     ratio(areas[k], areas), 1.0 if target == best else 0.0))
    return np.array(rows, dtype=np.float64)
