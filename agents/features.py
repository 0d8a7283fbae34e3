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
``FEATURE_NAMES`` are the first eleven, the stage-2 model's columns;
``POLICY_ITERATION_FEATURES`` adds ``BINDING_FEATURES`` (what policy iteration labels by
default); ``ALL_FEATURES`` adds ``STATE_FEATURES`` too, for students and rule searches that
name them.

The state features (issue 32, next steps) ask whether the student misses absolute scale and
the floor's state: the ratios above are scaled to the best candidate of each decision, so a
linear student cannot tell a 100 s from a 5,000 s difference, nor whether the work a
candidate releases goes to crews that are starving. In hours and hectometres: the
candidate's expected duration and tail, the walk to it, the work it releases at once (all of
it; weighted by each crew type's share of the remaining work per crew, ``load_shares``; of
types with an idle crew), the queued work of other types its area blocks (the same three
ways), of its own type, the successors' work it does not release alone, and the tail
weighted by the floor's progress. Measured on 11,569 policy-iteration labels (relabelled by
``distill relabel``, seed-fold CV with ``training.research.label_cv``): they add about 1 s a
decision to the linear student's ~19 s (docs/research-log.md); on the built-in floor duration
and tail never separate candidates (every task of a type has the same work).

``FloorFacts`` holds what depends on the case only (computed once per case);
``candidate_features`` reads the state at a decision. The first fifteen are scaled to about
[0, 1]; the state features are in hours and hectometres.
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
STATE_FEATURES = ("duration_h", "tail_h", "distance_hm", "releases_h", "releases_loaded_h",
                  "releases_idle_h", "blocks_h", "blocks_loaded_h", "blocks_idle_h",
                  "blocks_own_h", "successors_pending_h", "tail_late_h")
# what policy iteration labels and its students name by default (the committed students)
POLICY_ITERATION_FEATURES = FEATURE_NAMES + BINDING_FEATURES
ALL_FEATURES = POLICY_ITERATION_FEATURES + STATE_FEATURES
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
    columns = [rows, binding_features(facts, site, crew, targets)]
    if any(n in STATE_FEATURES for n in names):
        columns.append(state_features(facts, site, crew, position, targets))
    both = np.hstack(columns)
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


# -- state features (issue 32): absolute units and the floor's state ---------------------------

def load_shares(facts: FloorFacts, site) -> dict[str, float]:
    """Per crew type, its remaining expected work per crew (tasks not ended; a running task by
    its progress) over the largest among the types: 1 for the type that binds the rest of the
    floor now, less for the others."""
    remaining: dict[str, float] = {}
    for t in site.tasks:
        if t.pool == Pool.END:
            continue
        left = 1.0 - min(1.0, t.progress / t.work) if t.pool == Pool.ON and t.work > 0 else 1.0
        remaining[t.crew_type] = remaining.get(t.crew_type, 0.0) + facts.expected_s[t.index] * left
    crews: dict[str, int] = {}
    for c in site.crews:
        if c.status != CrewStatus.LEFT:
            crews[c.type] = crews.get(c.type, 0) + 1
    per_crew = {ct: w / max(1, crews.get(ct, 0)) for ct, w in remaining.items()}
    top = max(per_crew.values(), default=0.0)
    return {ct: (w / top if top > 0 else 0.0) for ct, w in per_crew.items()}


def idle_types(site) -> set[str]:
    """Crew types with a crew reaching without a target scope (idle, not away)."""
    return {c.type for c in site.crews if c.status == CrewStatus.REACHING and not c.scope
            and not c.absent}


def state_features(facts: FloorFacts, site, crew, position, targets: list[int]) -> np.ndarray:
    """``STATE_FEATURES`` per target: hours and hectometres rather than ratios, and the work a
    candidate releases or blocks weighted by how much its crew type binds the rest of the
    floor (``load_shares``) or whether a crew of that type stands idle."""
    tasks = [site.tasks[crew.scope[t]] for t in targets]
    share = load_shares(facts, site)
    idle = idle_types(site)
    progress = site.tasks_ended / max(1, len(site.tasks))
    h = 1.0 / 3600.0
    rows = []
    for k, task in enumerate(tasks):
        released = [s for s in task.successors
                    if all(site.tasks[p].pool == Pool.END for p in site.tasks[s].predecessors
                           if p != task.index)]
        pending = [s for s in task.successors if s not in released]
        blocked = [o for o in task.conflicts if site.tasks[o].pool == Pool.QUEUE]
        other = [o for o in blocked if site.tasks[o].crew_type != crew.type]
        own = [o for o in blocked if site.tasks[o].crew_type == crew.type]

        def work(ts, weight=lambda ct: 1.0):
            return h * sum(facts.expected_s[s] * weight(site.tasks[s].crew_type) for s in ts)

        tail = facts.tail_s[task.index] * h
        rows.append((facts.expected_s[task.index] * h, tail,
                     math.dist(position, site.target_points[targets[k]]) / 100.0,
                     work(released), work(released, lambda ct: share.get(ct, 0.0)),
                     work(released, lambda ct: float(ct in idle)),
                     work(other), work(other, lambda ct: share.get(ct, 0.0)),
                     work(other, lambda ct: float(ct in idle)),
                     work(own), work(pending), tail * progress))
    return np.array(rows, dtype=np.float64).reshape(len(tasks), len(STATE_FEATURES))
