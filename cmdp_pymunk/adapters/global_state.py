"""The global state s of the CMDP as one fixed-size float32 vector, for centralized critics.

``CMDPEnv.state()`` returns it and ``CMDPEnv.state_space`` bounds it (PettingZoo's state API;
the paper's MAPPO critic and TorchRL's ``return_state=True`` read it). Its size depends only on
the case: ``1 + 17 n_crews + 5 n_tasks + 2 n_storages + 3 + 2 n_crews`` floats (578 for the
built-in case: 7 crews, 87 tasks, 3 storages). ``state_layout(case)`` names every block.

Layout, in order (coordinates over the plane's half extents, as in Eq. 4):

- ``time`` (1): simulated seconds over the episode's time limit, in [0, 1];
- ``crews`` (17 per crew, in case order): x/x_max, y/y_max; cos and sin of the heading; status
  one-hot (reaching, tasking, fetching, waiting, deregistered, left); load over carry
  capacity (0 for a crew that carries nothing); 1 if it holds a target scope; x/x_max, y/y_max
  of its target (the highest-valued target of its scope; 0, 0 without one); its task
  (performed, waited on or paused) as (index + 1) / n_tasks, 0 for none; 1 if that task is
  paused for materials;
- ``tasks`` (5 per task, in case order): pool one-hot (wait, queue, on, end); progress over
  work;
- ``storages`` (2 per storage): stock over capacity; 1 if a crane lift to it is pending;
- ``crane`` (3): 1 while it serves a request; the remaining seconds of that request over the
  longer of the lift and assist times; requests waiting in its queue over n_crews;
- ``crane_queue`` (2 per crew): 1 if the crane serves this crew now; its place in the queue
  as 1 - k / n_crews for the k-th waiting request (k from 0; 1 is next), 0 if not queued;
- ``disruptions`` (only for a case with ``[disruptions]``: 2 + n_storages + n_crews): crane
  broken down, weather stop, each storage's delivery late, each crew absent
  (``disruptions.features``); a case without disruptions has no such block.
"""

from __future__ import annotations

import math

import numpy as np

from .. import disruptions
from ..cases.model import Case
from ..state import Site

CREW_FEATURES = 17
TASK_FEATURES = 5
STORAGE_FEATURES = 2
CRANE_FEATURES = 3
CRANE_QUEUE_FEATURES = 2


def state_layout(case: Case) -> list[tuple[str, int, int]]:
    """``(block, start, length)`` of every block of the state vector (see the module doc)."""
    n_crews, n_tasks, n_storages = len(case.crews), len(case.tasks), len(case.storages)
    blocks = [("time", 1), ("crews", CREW_FEATURES * n_crews), ("tasks", TASK_FEATURES * n_tasks),
              ("storages", STORAGE_FEATURES * n_storages), ("crane", CRANE_FEATURES),
              ("crane_queue", CRANE_QUEUE_FEATURES * n_crews)]
    if case.disruptions:
        blocks.append(("disruptions", disruptions.feature_size(case)))
    out, start = [], 0
    for name, length in blocks:
        out.append((name, start, length))
        start += length
    return out


def state_size(case: Case) -> int:
    _, start, length = state_layout(case)[-1]
    return start + length


def state_bounds(case: Case) -> tuple[np.ndarray, np.ndarray]:
    """(low, high): positions, cos and sin in [-1, 1], everything else in [0, 1]."""
    low = np.zeros(state_size(case), dtype=np.float32)
    high = np.ones_like(low)
    crews = next(start for name, start, _ in state_layout(case) if name == "crews")
    for c in range(len(case.crews)):
        at = crews + CREW_FEATURES * c
        low[at:at + 4] = -1.0  # x, y, cos, sin
        low[at + 12:at + 14] = -1.0  # its target's x, y
    return low, high


def global_state(site: Site, positions, headings, max_time_s: float) -> np.ndarray:
    """The state vector of the site now (see the module doc); the env clips it into
    ``state_bounds`` (a crew pressed against a wall can stand a hair past the plane's edge).

    Args:
        site: the construction state.
        positions: each crew's (x, y) in metres, in case order.
        headings: each crew's heading in radians.
        max_time_s: the episode's time limit in seconds.
    """
    case = site.case
    half_w, half_h = case.plane.half_extents
    n_crews, n_tasks = len(site.crews), len(site.tasks)
    out = np.zeros(state_size(case), dtype=np.float32)
    out[0] = site.time_s / max_time_s
    at = 1
    for crew in site.crews:
        row = out[at:at + CREW_FEATURES]
        x, y = positions[crew.index]
        row[0], row[1] = x / half_w, y / half_h
        row[2], row[3] = math.cos(headings[crew.index]), math.sin(headings[crew.index])
        row[4 + int(crew.status)] = 1.0
        row[10] = crew.load / crew.capacity if crew.capacity else 0.0
        if crew.scope:
            row[11] = 1.0
            target = max(crew.scope, key=lambda t: (crew.values.get(t, 0.0), -t))
            tx, ty = site.target_xy[target]
            row[12], row[13] = tx / half_w, ty / half_h
        if crew.task >= 0:
            row[14] = (crew.task + 1) / n_tasks
            row[15] = 1.0 if crew.paused else 0.0
        at += CREW_FEATURES
    for task in site.tasks:
        out[at + int(task.pool)] = 1.0
        out[at + 4] = task.progress / task.work
        at += TASK_FEATURES
    for storage in site.storages:
        out[at] = storage.stock / storage.capacity
        out[at + 1] = 1.0 if storage.lift_pending else 0.0
        at += STORAGE_FEATURES
    crane = site.crane
    longest = max(case.crane.lift_time_s, case.crane.assist_time_s) or 1.0
    if crane.current is not None:
        out[at] = 1.0
        out[at + 1] = crane.remaining_s / longest
        out[at + 3 + CRANE_QUEUE_FEATURES * crane.current.crew] = 1.0
    out[at + 2] = len(crane.queue) / n_crews
    for k, request in enumerate(crane.queue):
        place = at + 3 + CRANE_QUEUE_FEATURES * request.crew + 1
        out[place] = max(out[place], 1.0 - k / n_crews)
    if case.disruptions:
        at += CRANE_FEATURES + CRANE_QUEUE_FEATURES * n_crews
        disruptions.features(site, out[at:])
    return out


__all__ = ["global_state", "state_bounds", "state_layout", "state_size"]
