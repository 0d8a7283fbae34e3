"""Construction state S_cons and the crews' status: task pools, stocks, loads, the crane queue.

The site is plain data; the stages (``decide``, ``construct``, ``move``...) change it. Everything
here is indexed by integers fixed at construction: tasks, components, storages, crews, and the
*targets* (every component, then every storage, then the outlet), which are what rays can see
and what the target evaluator values.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from .cases.model import Case, CrewType
from .cases.reach import Reach, laying_tasks
from .geometry import Outline, grown
from .geometry import overlap as shapes_overlap
from .precedence import ON, QUEUE, Pool, initial_pools

Rect = tuple[float, float, float, float]  # (x0, y0, x1, y1); or a ``geometry.Outline``


class CrewStatus(IntEnum):
    REACHING = 0  # target reaching, with or without a target scope
    TASKING = 1
    FETCHING = 2  # fetching materials at a storage
    WAITING = 3  # waiting for the crane
    DEREGISTERED = 4  # no work of its type remains: heading for the outlet
    LEFT = 5  # gone through the outlet


class IdleCause(IntEnum):
    """Why a reaching crew holds no target (section 5.3, Fig. 14)."""

    NONE = 0
    PREDECESSOR = 1  # its remaining tasks wait for predecessors
    AREA = 2  # its queued tasks are blocked by other crews' task areas
    NO_TARGET = 3  # anything else (e.g. its queued tasks are being worked by its peers)
    # A disruption keeps it from working (``disruptions``; beyond the paper): any status.
    CRANE_BREAKDOWN = 4
    LATE_DELIVERY = 5
    ABSENCE = 6
    WEATHER = 7


# The causes a reaching crew without a target has (``decide.acquire_target``), and those of
# a crew a disruption keeps from working (``disruptions.blocking_cause``).
REACHING_IDLE_CAUSES = (IdleCause.PREDECESSOR, IdleCause.AREA, IdleCause.NO_TARGET)
DISRUPTION_CAUSES = (IdleCause.CRANE_BREAKDOWN, IdleCause.LATE_DELIVERY, IdleCause.ABSENCE,
                     IdleCause.WEATHER)
# their columns in episode rows and comparisons: crew-seconds kept from working, by kind
DISRUPTION_IDLE_FIELDS = tuple(f"idle_{c.name.lower()}" for c in DISRUPTION_CAUSES)


class ScopeKind(IntEnum):
    NONE = 0
    TASKS = 1  # components with executable tasks of its type
    STORAGES = 2  # storages of its material
    PAUSED = 3  # its paused task
    OUTLET = 4


# The members as module names, for the code that runs for every crew at every step (the
# decision table, P_cons, R_e's terms, the event floor): on Python 3.11 a member read off its
# class (``CrewStatus.TASKING``) goes through the enum metaclass's ``__getattr__`` hook and
# costs ~65 ns, a module name ~10 (a tenth of an event floor's time). The same objects.
REACHING, TASKING, FETCHING, WAITING, DEREGISTERED, LEFT = (
    CrewStatus.REACHING, CrewStatus.TASKING, CrewStatus.FETCHING, CrewStatus.WAITING,
    CrewStatus.DEREGISTERED, CrewStatus.LEFT)
NO_SCOPE, TASKS, STORAGES, PAUSED, OUTLET = (
    ScopeKind.NONE, ScopeKind.TASKS, ScopeKind.STORAGES, ScopeKind.PAUSED, ScopeKind.OUTLET)

MOVING = (REACHING, DEREGISTERED)


def expand(rect: Rect, by: float) -> Rect:
    return (rect[0] - by, rect[1] - by, rect[2] + by, rect[3] + by)


def rect_of(x: float, y: float, w: float, h: float) -> Rect:
    return (x - w / 2, y - h / 2, x + w / 2, y + h / 2)


def inside(x: float, y: float, r: Rect) -> bool:
    """Whether (x, y) lies in the rectangle, or the polygon of an ``Outline`` (edges in)."""
    if r[0] <= x <= r[2] and r[1] <= y <= r[3]:
        return type(r) is not Outline or r.contains(x, y)
    return False


def overlap(a: Rect, b: Rect) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def overlaps(rects: list[Rect]) -> np.ndarray:
    """``overlap`` of every pair at once (made for every episode: a loop over the pairs was
    a few percent of an event floor): ``[i, j]`` whether rects i and j overlap."""
    r = np.asarray(rects, dtype=np.float64).reshape(-1, 4)
    a, b = r[:, None, :], r[None, :, :]
    return ((a[..., 0] < b[..., 2]) & (b[..., 0] < a[..., 2]) & (a[..., 1] < b[..., 3])
            & (b[..., 1] < a[..., 3]))


@dataclass(eq=False)
class TaskState:
    index: int
    id: str
    type: str
    component: int
    crew_type: str
    work: float
    material: str | None
    material_per_work: float  # material consumed per unit of work
    needs_crane: bool
    area: Rect  # the task area: the component grown by Table 2's area distance (an Outline
    # for a polygon component: its box to whatever needs a box, ``inside`` tests the polygon)
    congestion_index: float  # Table 2, I_area inside the task area
    predecessors: tuple[int, ...]
    successors: tuple[int, ...] = ()
    all_successors: int = 0  # transitive successors, O^e3 and Eq. 9's Suc
    conflicts: tuple[int, ...] = ()  # tasks whose areas overlap this one's (space conflicts)
    pool: Pool = Pool.WAIT
    progress: float = 0.0
    pace: float = 0.0  # work per second, drawn from Table 3 when the task is initiated
    crew: int = -1
    crane_assisted: bool = False
    started_s: float = -1.0
    ended_s: float = -1.0


@dataclass(eq=False)
class StorageState:
    index: int
    id: str
    material: str
    rect: Rect
    capacity: float
    congestion_index_full: float
    target: int
    stock: float = 0.0
    lift_pending: bool = False
    # the lowest decision level the logistics role was asked at since the last lift landed
    # (``construct.decision_level``); inf: none yet
    asked_at: float = math.inf


@dataclass(eq=False)
class ComponentState:
    index: int
    id: str
    kind: str
    rect: Rect  # its rectangle, or its ``geometry.Outline`` (a tuple too: the box)
    tasks: tuple[int, ...]  # its tasks in precedence order


@dataclass
class CraneRequest:
    crew: int
    kind: str  # "material" or "task"
    storage: int = -1
    task: int = -1


@dataclass(eq=False)
class CraneState:
    queue: deque = field(default_factory=deque)
    current: CraneRequest | None = None
    remaining_s: float = 0.0


@dataclass(eq=False)
class CrewStats:
    """Per-crew counters for summaries and the evaluation reward (section 5.3)."""

    reaching_steps: int = 0
    idle_steps: dict = field(default_factory=lambda: {c: 0 for c in IdleCause if c})
    distance_m: float = 0.0
    material_trips: int = 0
    crane_waits: int = 0
    crane_wait_steps: int = 0
    reaches: int = 0
    reach_timeouts: int = 0  # reevaluate_after_steps steps holding a target without reaching
    collisions: int = 0
    congestion_entries: int = 0


@dataclass(eq=False)
class CrewState:
    """One crew: its status, load, task, and target scope with its values.

    ``scope`` and ``values`` are replaced by new dicts, never changed in place: the reaching
    observation is cached on their identity (``env.CMDPEnv._observe``).
    """

    index: int
    id: str
    type: str
    spec: CrewType
    material: str | None
    capacity: float
    status: CrewStatus = CrewStatus.REACHING
    load: float = 0.0
    task: int = -1  # the task it performs, waits on, or has paused
    paused: bool = False
    storage: int = -1  # the storage it fetches at
    scope_kind: ScopeKind = ScopeKind.NONE
    scope: dict = field(default_factory=dict)  # target index -> task index (or -1)
    values: dict = field(default_factory=dict)  # target index -> V_Tar
    scope_version: int = -1
    steps_since_reach: int = 0  # steps holding a target since the last reach
    # target -> (x, y, time_s): where the crew last saw it in its scope, or left it paused
    sightings: dict = field(default_factory=dict)
    idle_cause: IdleCause = IdleCause.NONE
    stats: CrewStats = field(default_factory=CrewStats)
    absent: bool = False  # away from the plane (a disruption): it neither moves nor decides
    disruption: IdleCause = IdleCause.NONE  # the disruption keeping it from working, if any

    @property
    def moving(self) -> bool:
        return self.status in MOVING and not self.absent

    def clear_scope(self) -> None:
        """No target scope, and none current: c10 acquires one at its next chance."""
        self.scope_kind = NO_SCOPE
        self.scope = {}
        self.values = {}
        self.scope_version = -1


class Site:
    """The whole construction state of one episode."""

    def __init__(self, case: Case, stage: int):
        self.case = case
        self.stage = stage
        self.time_s = 0.0
        self.version = 0  # bumped whenever pools or task areas change: scopes go stale
        comp_index = {c.id: i for i, c in enumerate(case.components)}
        self.tasks: list[TaskState] = []
        for i, (t, (area, predecessors, successors, conflicts, below)) in enumerate(
                zip(case.tasks, task_layout(case), strict=True)):
            tt = case.task_types[t.type]
            task = TaskState(
                index=i, id=t.id, type=t.type, component=comp_index[t.component],
                crew_type=tt.crew_type, work=t.work, material=tt.material,
                material_per_work=t.material_quantity / t.work if tt.material else 0.0,
                needs_crane=tt.needs_crane, area=area,
                congestion_index=tt.congestion_index, predecessors=predecessors)
            task.successors, task.conflicts, task.all_successors = successors, conflicts, below
            self.tasks.append(task)
        of_component: list[list[int]] = [[] for _ in case.components]  # in task order
        for t in self.tasks:
            of_component[t.component].append(t.index)
        self.components = [
            ComponentState(i, c.id, c.kind, c.shape, tuple(of_component[i]))
            for i, c in enumerate(case.components)]
        n_comp = len(self.components)
        self.storages = [
            StorageState(i, s.id, s.material, rect_of(s.x_m, s.y_m, s.width_m, s.height_m),
                         s.capacity, s.congestion_index_full, target=n_comp + i)
            for i, s in enumerate(case.storages)]
        self.outlet_target = n_comp + len(self.storages)
        self.n_targets = self.outlet_target + 1
        pos = [(c.x_m, c.y_m) for c in case.components]
        pos += [(s.x_m, s.y_m) for s in case.storages]
        pos.append((case.plane.outlet_x_m, case.plane.outlet_y_m))
        self.target_xy = np.array(pos, dtype=np.float64)
        # the same points as plain floats: a distance to a numpy row costs ten times more
        self.target_points: list[tuple[float, float]] = [(float(x), float(y)) for x, y in pos]
        self.crane = CraneState()
        self.crews: list[CrewState] = []
        for i, c in enumerate(case.crews):
            spec = case.crew_types[c.type]
            materials = {tt.material for tt in case.task_types.values()
                         if tt.crew_type == c.type and tt.material}
            material = sorted(materials)[0] if materials else None
            self.crews.append(CrewState(i, c.id, c.type, spec, material,
                                        spec.carry_capacity if material else 0.0))
        # Each crew type's tasks, for the decision table's target acquisition.
        self.tasks_of_crew_type: dict[str, tuple[int, ...]] = {
            ct: tuple(t.index for t in self.tasks if t.crew_type == ct) for ct in case.crew_types}
        self.active_areas: list[int] = []  # tasks whose areas are on the plane (pool ON)
        self.tasks_ended = 0
        # crew type -> (version, its queued tasks, any waiting, the queued ones executable):
        # ``decide.acquire_target`` asks it for every crew of the type at every version
        self.pools_by_type: dict[str, tuple] = {}
        # Decks (``Component.deck``): walked on once laid. Which task lays which deck (task
        # index -> component index), the decks laid so far, and who reaches what over them;
        # a floor without decks has none of it and runs as before.
        task_index = {t.id: i for i, t in enumerate(case.tasks)}
        self.laying: dict[int, int] = {task_index[t]: comp_index[c]
                                       for t, c in laying_tasks(case).items()}
        self.laid: frozenset[int] = frozenset()
        self.reach = Reach.of(case) if self.laying else None
        self.starts = [(c.start_x_m, c.start_y_m) for c in case.crews]

        self.disrupted = None  # disruptions.Now during the coming second; None: no disruptions
        self.reset_pools()

    # -- queries the stages share ------------------------------------------------------------

    def executable(self, task: TaskState) -> bool:
        """Queued, and no space conflict with a task area already on the plane."""
        if task.pool != QUEUE:
            return False
        tasks = self.tasks
        for o in task.conflicts:  # a plain loop: asked for every queued task at every c10
            if tasks[o].pool == ON:
                return False
        return True

    def reachable(self, crew: CrewState, task: TaskState) -> bool:
        """Whether the crew reaches the task's work point now, from its start over open floor
        and the decks laid so far (open floor only grows, so wherever the crew stands lies in
        its start's region); always on a floor without decks (the case check proved it)."""
        if self.reach is None:
            return True
        return self.reach.reaches(crew.spec.radius_m, self.starts[crew.index], task.index,
                                  self.laid)

    def lay(self, task: TaskState) -> int:
        """The deck that ``task`` lays, now laid (walked on from here on), or -1."""
        deck = self.laying.get(task.index, -1)
        if deck >= 0:
            self.laid = self.laid | {deck}
        return deck

    def in_congestion_area(self, x: float, y: float) -> bool:
        """Inside an active task area or a storage area: where an idle crew is in the way."""
        return any(inside(x, y, self.tasks[t].area) for t in self.active_areas) or any(
            inside(x, y, s.rect) for s in self.storages)

    def storage_congestion(self, storage: StorageState) -> float:
        """I_area of a storage (Eq. 1): 1 when empty, falling to its full index with the stock."""
        fill = min(1.0, storage.stock / storage.capacity)
        return 1.0 - (1.0 - storage.congestion_index_full) * fill

    @property
    def done(self) -> bool:
        return self.tasks_ended == len(self.tasks)

    def reset_pools(self) -> None:
        initial_pools(self)


_LAYOUTS: dict[int, tuple] = {}  # id(case) -> (the case, ``task_layout``'s answer)


def task_layout(case: Case) -> list[tuple]:
    """What a case fixes of its tasks, per task in case order: (task area, predecessors,
    successors, tasks whose areas overlap its own, how many tasks follow it at any depth).
    Worked out once per case object (a case is frozen) and shared by every episode's
    ``Site``: the overlaps of every pair of areas were a few percent of an event floor's
    reset."""
    held = _LAYOUTS.get(id(case))
    if held is not None and held[0] is case:
        return held[1]
    comp_index = {c.id: i for i, c in enumerate(case.components)}
    task_index = {t.id: i for i, t in enumerate(case.tasks)}
    areas = [grown(case.components[comp_index[t.component]].shape,
                   case.task_types[t.type].area_distance_m) for t in case.tasks]
    preds = [tuple(task_index[p] for p in t.predecessors) for t in case.tasks]
    succ: list[list[int]] = [[] for _ in case.tasks]
    for i, ps in enumerate(preds):
        for p in ps:
            succ[p].append(i)
    conflicting = overlaps(areas)
    np.fill_diagonal(conflicting, False)
    # a polygon's box may overlap where the polygons do not: those pairs are asked again
    for i in [k for k, a in enumerate(areas) if isinstance(a, Outline)]:
        for j in np.flatnonzero(conflicting[i]).tolist():
            if not shapes_overlap(areas[i], areas[j]):
                conflicting[i, j] = conflicting[j, i] = False
    out = [(areas[i], preds[i], tuple(succ[i]),
            tuple(np.flatnonzero(conflicting[i]).tolist()), len(_descendants(i, succ)))
           for i in range(len(areas))]
    if len(_LAYOUTS) >= 16:  # many cases in one process (a sweep of layouts)
        _LAYOUTS.clear()
    _LAYOUTS[id(case)] = (case, out)
    return out


def _descendants(start: int, succ: list[list[int]]) -> set[int]:
    seen: set[int] = set()
    stack = list(succ[start])
    while stack:
        n = stack.pop()
        if n not in seen:
            seen.add(n)
            stack.extend(succ[n])
    return seen


def activity(crew: CrewState) -> str:
    """What the crew is doing, in the categories of the agents' Gantt chart (Fig. 9); a crew
    a disruption keeps from working is ``idle_<kind>`` (``disruptions``)."""
    if crew.disruption:
        return _IDLE_ACTIVITY[crew.disruption]
    if crew.status == REACHING:
        if crew.scope:
            return "navigating"
        return _IDLE_ACTIVITY[crew.idle_cause]
    return _STATUS_ACTIVITY[crew.status]


# the names ``activity`` gives, made once (it is asked for every crew at every event)
_IDLE_ACTIVITY = {c: "idle_" + (c.name.lower() if c else "no_target") for c in IdleCause}
_STATUS_ACTIVITY = {s: s.name.lower() for s in CrewStatus}


ACTIVITIES = ("navigating", "idle_predecessor", "idle_area", "idle_no_target", "tasking",
              "fetching", "waiting", "deregistered", "left")
# a disruption's idle activities (``disruptions``), after the paper's
DISRUPTED_ACTIVITIES = ("idle_crane_breakdown", "idle_late_delivery", "idle_absence",
                        "idle_weather")
