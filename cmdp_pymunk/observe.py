"""Observations: the reaching policy's rays with Eq. 3, and the evaluation policy's O^e.

Reaching observation (section 3.6.2), ``(n + m) * 4 + 3`` floats (115 for 12 + 16 rays):
for each ray, in order (frontal rays left to right, then surrounding rays anticlockwise from
straight ahead):

- relative length: hit distance over the ray's length (1 when the ray hits nothing);
- emission angle relative to the heading, over pi (in [-1, 1]);
- type id of the object hit over 6: 0 nothing, 1 wall, 2 component, 3 crew, 4 task area,
  5 storage, 6 outlet;
- priority value after Eq. 3: V_Tar if the object is in the crew's target scope, else 0.

then the crew's velocity in its own frame (forward, left) and its speed, each over its nominal
forward velocity.

With the case's ``target_memory`` on (beyond the paper: its section 6 names a "memory storage"
as the remedy for blind spots among components), 4 more floats: the latest sighting of a
target of the crew's current scope, as (1, forward offset, left offset, age), the offsets over
the sight distance in the crew's frame and the age over the re-evaluation step cap (capped at
1); all 0 while it remembers none. A crew keeps, per target, the last point where one of its
frontal rays hit that target while it was in the scope (a non-zero value after Eq. 3), and the
point where it paused a task to fetch materials (it knows where it left its work). Targets never
move, so a sighting stays true.

What rays see of sensor areas: frontal rays (to the sight distance, within the field of view)
look through task areas, so that targets stay visible behind the congestion in front of them;
they stop at storages and the outlet, which are targets themselves, except at the storage the
crew stands in (a ray that starts inside a shape would hit it at once and leave the crew
blind until it has walked out). Surrounding rays (short,
all around) stop at every area, task areas included, so they report the congestion around
the crew (a ray that starts inside an area hits it at length 0). A crew's rays never hit the
crew itself (shared ``ShapeFilter`` group).
"""

from __future__ import annotations

import math

import numpy as np

from . import disruptions
from .physics import N_KINDS, STORAGE, Physics
from .state import CrewState, Pool, Site

_UNSTARTED = (Pool.QUEUE, Pool.WAIT)  # as module names: asked per target at every decision

VELOCITY_FEATURES = 3
MEMORY_FEATURES = 4
VALUES_PER_RAY = 4
TYPE_SCALE = 1.0 / (N_KINDS - 1)
_NO_HIT = (1.0, 0.0, 0.0)  # relative length 1, type "nothing", priority 0


def modified_priority(target: int, scope, values) -> float:
    """A ray's priority value after Eq. (3): V_j = V_ray if ray_j in {Tar}, else 0.

    Args:
        target: the target index of the object the ray hit (-1: not a target at all).
        scope: the crew's target scope {Tar} (a container of target indices).
        values: V_Tar per target, from the target evaluator.
    """
    if target >= 0 and target in scope:
        return values.get(target, 0.0)
    return 0.0


class RayModel:
    """The ray layout of Fig. 3, computed once per env."""

    def __init__(self, n_frontal: int, n_surrounding: int, fov_deg: float, sight_m: float,
                 surrounding_m: float, memory: bool = False, memory_age_s: float = 300.0):
        half = math.radians(fov_deg) / 2.0
        frontal = [(-half + 2 * half * k / (n_frontal - 1)) if n_frontal > 1 else 0.0
                   for k in range(n_frontal)]
        surrounding = [2 * math.pi * k / n_surrounding for k in range(n_surrounding)]
        # (unit x, unit y, length, frontal?) in the crew's frame
        self.rays = [(math.cos(a), math.sin(a), sight_m, True) for a in frontal] + \
                    [(math.cos(a), math.sin(a), surrounding_m, False) for a in surrounding]
        self.n_rays = len(self.rays)
        self.sight_m = sight_m
        self.memory = memory
        self.memory_age_s = memory_age_s
        self.velocity_at = self.n_rays * VALUES_PER_RAY
        self.size = self.velocity_at + VELOCITY_FEATURES + (MEMORY_FEATURES if memory else 0)
        angles = frontal + [math.atan2(math.sin(a), math.cos(a)) for a in surrounding]
        self.template = np.zeros(self.size, dtype=np.float32)
        self.template[1:self.n_rays * VALUES_PER_RAY:VALUES_PER_RAY] = np.array(angles) / math.pi
        self.template[0:self.n_rays * VALUES_PER_RAY:VALUES_PER_RAY] = 1.0
        # where each ray's three cast values go: relative length, type id, priority
        self.slots = np.array([[VALUES_PER_RAY * j, VALUES_PER_RAY * j + 2,
                                VALUES_PER_RAY * j + 3] for j in range(self.n_rays)]).ravel()

    def endpoints(self, x: float, y: float, angle: float):
        c, s = math.cos(angle), math.sin(angle)
        return [(x + (c * ux - s * uy) * length, y + (s * ux + c * uy) * length, frontal)
                for ux, uy, length, frontal in self.rays]


def ray_model(case) -> RayModel:
    """The case's ray layout (its simulation settings)."""
    sim = case.simulation
    return RayModel(sim.frontal_rays, sim.surrounding_rays, sim.field_of_view_deg,
                    sim.sight_distance_m, sim.surrounding_distance_m, sim.target_memory,
                    sim.reevaluate_after_steps * sim.step_s)


def observation_bounds(rays: RayModel, case) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) of every reaching-observation float, from what each feature can be.

    - relative length, type id over 6, priority value V_Tar: [0, 1] (evaluators give V_Tar in
      [0, 1]; ``as_target_values`` maps Eqs. 4 and 9 onto [0.5, 1]);
    - emission angle over pi: [-1, 1];
    - velocities over the crew's nominal forward velocity v_f: a crew moves at most at
      hypot(v_f, v_l) (forward plus lateral, Eq. 1 only slows it), and a crew pushed by
      another moves no faster than the pusher. So no crew's speed exceeds the fastest
      crew type's hypot(v_f, v_l), and over the slowest type's v_f that is the cap
      (2.36 in the built-in case): forward and left in [-cap, cap], speed in [0, cap];
    - target memory: the flag and the age in [0, 1]; the offsets join two points of the plane,
      so they lie within +-(plane diagonal / sight distance).

    The env clips observations into these bounds (contact impulses could in principle
    overshoot the cap; no soak here has).
    """
    low = np.zeros(rays.size, dtype=np.float32)
    high = np.ones(rays.size, dtype=np.float32)
    low[1:rays.n_rays * VALUES_PER_RAY:VALUES_PER_RAY] = -1.0  # emission angles
    lateral = case.simulation.lateral_velocity_m_s
    types = case.crew_types.values()
    cap = max(math.hypot(t.velocity_m_s, lateral) for t in types) / \
        min(t.velocity_m_s for t in types)
    at = rays.velocity_at
    low[at:at + 2] = -cap
    high[at:at + 3] = cap
    if rays.memory:
        reach = math.hypot(case.plane.width_m, case.plane.height_m) / rays.sight_m
        low[at + 4:at + 6] = -reach
        high[at + 4:at + 6] = reach
    return low, high


def observe_crew(world: Physics, rays: RayModel, crew: CrewState,
                 now_s: float = 0.0) -> np.ndarray:
    """Cast the crew's rays and return its reaching observation (see the module doc); the
    memory features, if any, are left 0 (``remembered_target`` fills them). With the memory
    on, records in ``crew.sightings`` where its frontal rays hit targets of its scope."""
    x, y, angle = world.pose(crew.index)
    c, s = math.cos(angle), math.sin(angle)
    start = (x, y)
    query, frontal_filter, surrounding_filter = world.ray_query(crew.index)
    scope, values, memory = crew.scope, crew.values, rays.memory
    cast: list[float] = []
    sightings = crew.sightings
    # the hottest loop of a step (28 rays a deciding crew): ``RayModel.endpoints`` and
    # ``modified_priority`` (Eq. 3) written out in place, the same arithmetic
    for ux, uy, length, frontal in rays.rays:
        end = (x + (c * ux - s * uy) * length, y + (s * ux + c * uy) * length)
        hit = query(start, end, frontal_filter if frontal else surrounding_filter)
        if hit is None:
            cast += _NO_HIT
            continue
        if frontal and hit[0] == 0.0 and hit[1] == STORAGE:
            hit = _cast_out_of(query, world.storage_rects[hit[2]], start, end, frontal_filter)
            if hit is None:
                cast += _NO_HIT
                continue
        alpha, kind, target = hit
        value = values.get(target, 0.0) if target >= 0 and target in scope else 0.0
        cast += (alpha, kind * TYPE_SCALE, value)
        if frontal and value > 0.0 and memory:
            sightings[target] = (x + alpha * (end[0] - x), y + alpha * (end[1] - y), now_s)
    obs = rays.template.copy()
    obs[rays.slots] = cast
    vx, vy = world.velocity(crew.index)
    v_nominal = crew.spec.velocity_m_s
    at = rays.velocity_at
    obs[at] = (c * vx + s * vy) / v_nominal
    obs[at + 1] = (-s * vx + c * vy) / v_nominal
    obs[at + 2] = math.hypot(vx, vy) / v_nominal
    return obs


def _cast_out_of(query, rect, start, end, mode):
    """A frontal ray from a crew standing in a storage: cast again (``query``, in ``mode``)
    from where the ray leaves the storage, so that the crew is not blind while it fetches and
    walks out. The answer's alpha is along the whole ray."""
    (x, y), (ex, ey) = start, end
    dx, dy = ex - x, ey - y
    t_out = 1.0
    for d, p, lo, hi in ((dx, x, rect[0], rect[2]), (dy, y, rect[1], rect[3])):
        if d > 0:
            t_out = min(t_out, (hi - p) / d)
        elif d < 0:
            t_out = min(t_out, (lo - p) / d)
    t_out = t_out + 1e-6
    if t_out >= 1.0:  # the whole ray lies in the storage
        return None
    hit = query((x + t_out * dx, y + t_out * dy), end, mode)
    if hit is None:
        return None
    return t_out + hit[0] * (1.0 - t_out), hit[1], hit[2]


def remembered_target(rays: RayModel, crew: CrewState, x: float, y: float, heading: float,
                      now_s: float) -> tuple[float, float, float, float]:
    """The memory features: (1, forward, left, age) of the latest sighting of a target in the
    crew's scope (offsets over the sight distance, age over the step cap), else zeros."""
    latest = None
    for target in crew.scope:
        seen = crew.sightings.get(target)
        if seen is not None and (latest is None or seen[2] > latest[2]):
            latest = seen
    if latest is None:
        return (0.0, 0.0, 0.0, 0.0)
    dx, dy = latest[0] - x, latest[1] - y
    c, s = math.cos(heading), math.sin(heading)
    return (1.0, (c * dx + s * dy) / rays.sight_m, (-s * dx + c * dy) / rays.sight_m,
            min(1.0, (now_s - latest[2]) / rays.memory_age_s))


class ReachingObservations:
    """Every crew's reaching observation on an engine's floor, by crew index: the one place
    rays are cast for a low level (the PettingZoo env and the stage-2 env both ask here).

    Rays are cast only for crews that need a movement decision (``engine.needs_action``);
    the others get all zeros. A crew's rays are cast again only when something moved
    (``world.motion_version``) or its scope or values changed (the stages replace them, never
    change them in place: ``state.CrewState``). The memory age moves on every second. Every
    observation is clipped into ``bounds`` (``observation_bounds``). ``reset()`` at every
    episode.
    """

    def __init__(self, case):
        self.rays = ray_model(case)
        self.low, self.high = observation_bounds(self.rays, case)
        self.idle = np.zeros(self.rays.size, dtype=np.float32)
        self._cache: list = [None] * len(case.crews)

    def reset(self) -> None:
        self._cache = [None] * len(self._cache)

    def crew(self, engine, i: int) -> np.ndarray:
        """Crew i's reaching observation now (a fresh array)."""
        site, world = engine.site, engine.world
        crew = site.crews[i]
        if not engine.needs_action(crew):
            return self.idle.copy()
        cached = self._cache[i]
        if cached is None or cached[0] != world.motion_version or cached[1] is not crew.scope \
                or cached[2] is not crew.values:
            cached = (world.motion_version, crew.scope, crew.values,
                      observe_crew(world, self.rays, crew, site.time_s))
            self._cache[i] = cached
        obs = cached[3].copy()
        if self.rays.memory:  # the age moves on even when nothing else does
            x, y = engine.positions[i]
            obs[-MEMORY_FEATURES:] = remembered_target(self.rays, crew, x, y,
                                                       engine.pose(i)[2], site.time_s)
        return np.clip(obs, self.low, self.high, out=obs)  # the space's promise

    def all(self, engine) -> list[np.ndarray]:
        """Every crew's reaching observation, in crew order."""
        return [self.crew(engine, i) for i in range(len(engine.site.crews))]


# -- the evaluation policy's observation O^e (section 3.6.1) -----------------------------------

CREW_FEATURES = 5  # x/x_max, y/y_max, cos(heading), sin(heading), load / capacity
TARGET_FEATURES = 12
EXPECTED_TIME_SCALE_S = 3600.0


def n_targets(case) -> int:
    """Every potential target of the case: its components, its storages and the outlet."""
    return len(case.components) + len(case.storages) + 1


def evaluation_size(case) -> int:
    """The length of O^e for the case: the crew's 5 floats and 12 per potential target, and
    for a case with disruptions what is disrupted (``disruptions.feature_size``)."""
    return CREW_FEATURES + TARGET_FEATURES * n_targets(case) + disruptions.feature_size(case)


def evaluation_bounds(case) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) of every float of ``evaluation_observation`` for the case, from the case
    alone (no episode needed).

    All are in [-1, 1] but two columns of each target row: the congestion-area scale
    (largest area distance / 3 m) and the expected action time (the longest task's mean
    duration / 3600 s), whose highs come from the case.
    """
    area_high = max(t.area_distance_m for t in case.task_types.values()) / 3.0
    time_high = max(case.crew_types[case.task_types[t.type].crew_type].mean_seconds(t.work)
                    for t in case.tasks) / EXPECTED_TIME_SCALE_S
    row_low = np.array([0, 0, 0, -1, -1, -1, 0, 0, 0, 0, 0, 0], dtype=np.float32)
    row_high = np.array([1, 1, 1, 1, 1, 1, max(1.0, area_high), max(1.0, time_high), 1, 1, 1, 1],
                        dtype=np.float32)
    targets = n_targets(case)
    extra = disruptions.feature_size(case)
    low = np.concatenate([np.array([-1, -1, -1, -1, 0], np.float32), np.tile(row_low, targets),
                          np.zeros(extra, np.float32)])
    high = np.concatenate([np.ones(CREW_FEATURES, np.float32), np.tile(row_high, targets),
                           np.ones(extra, np.float32)])
    return low, high


def evaluation_observation(site: Site, crew: CrewState, position, heading: float,
                           bounds: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """O^e0..O^e4 for every potential target of the episode (fixed size), from the crew's view,
    clipped into ``bounds`` (``evaluation_bounds(case)``, made once by the caller): a crew
    pressed against the plane's edge stands a hair past it. The one O^e that training and
    deployment (``agents.models.ModelEvaluator``) both read.

    The crew's own 5 floats (x/x_max, y/y_max, cos and sin of its heading, load share), then
    per target (components, then storages, then the outlet) 12 floats:

    - O^e0 (0-7): kind one-hot (component, storage, outlet); pool of the crew's task there
      (wait 0, queue 1/3, on 2/3, end 1; -1 if it has none there); x/x_max, y/y_max;
      congestion-area scale (area distance / 3 m); expected remaining action time / 3600 s;
    - O^e1 (8): 1 if the target is in the crew's current target scope;
    - O^e2 (9): distance to the crew over the plane's diagonal;
    - O^e3 (10): all successors of the crew's task there, over the number of tasks;
    - O^e4 (11): tasks in queue or wait whose areas conflict with it, over the number of tasks.

    Beyond the paper, a case with disruptions appends what is disrupted now
    (``disruptions.features``); a model trained without them is refused (its size differs).

    Args:
        site: the construction state; crew: the deciding crew; position: its (x, y) in m;
        heading: its heading in radians; bounds: (low, high) as above.
    """
    half_w, half_h = site.case.plane.half_extents
    diag = 2.0 * math.hypot(half_w, half_h)
    n_tasks = len(site.tasks)
    out = np.zeros(CREW_FEATURES + TARGET_FEATURES * site.n_targets
                   + disruptions.feature_size(site.case), dtype=np.float32)
    out[:CREW_FEATURES] = (position[0] / half_w, position[1] / half_h, math.cos(heading),
                           math.sin(heading), crew.load / crew.capacity if crew.capacity else 0.0)
    tasks = site.tasks
    mine = {tasks[t].component: tasks[t] for t in site.tasks_of_crew_type[crew.type]}
    spec = crew.spec
    end = CREW_FEATURES + TARGET_FEATURES * site.n_targets
    if end < len(out):
        disruptions.features(site, out[end:])
    n_comp, outlet, scope = len(site.components), site.outlet_target, crew.scope
    x, y = position[0], position[1]
    # every target's row as plain floats, written into the array at once (one float32 cast
    # each, as element by element): a write per float cost more than the rest
    values: list[float] = []
    for target, (tx, ty) in enumerate(site.target_points):
        row = [0.0] * TARGET_FEATURES
        kind = 0 if target < n_comp else (1 if target < outlet else 2)
        row[kind] = 1.0
        row[3] = -1.0
        row[4], row[5] = tx / half_w, ty / half_h
        task = mine.get(target) if kind == 0 else None
        if task is not None:
            row[3] = int(task.pool) / 3.0
            row[6] = site.case.task_types[task.type].area_distance_m / 3.0
            remaining = 1.0 - task.progress / task.work
            row[7] = spec.mean_seconds(task.work) * remaining / EXPECTED_TIME_SCALE_S
            row[10] = task.all_successors / n_tasks
            row[11] = sum(tasks[o].pool in _UNSTARTED for o in task.conflicts) / n_tasks
        row[8] = 1.0 if target in scope else 0.0
        row[9] = math.hypot(tx - x, ty - y) / diag
        values += row
    out[CREW_FEATURES:end] = values
    return np.clip(out, bounds[0], bounds[1], out=out)
