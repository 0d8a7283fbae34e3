"""Pi_cons: the construction-knowledge decision table (Table 1) held as data.

Every step, for every crew still on the plane, the rows are tried in ``DECISION_TABLE``'s
order and the first whose trigger holds fires. A row that changes the crew's state may be
followed by another in the same step (at most ``MAX_ROWS_PER_STEP``), so that, e.g., a crew
that completes a task (c9) acquires its next target scope (c10) at once instead of standing
one second without one. c2 (execute) only marks the task as progressing: ``construct`` moves
it on in the next step's P_cons.

Where Table 1 is silent, this reading is used (docs/case-study.md lists them):
- "Equipment" is always sufficient: the crews marked * in Table 3 carry their own.
- "Material sufficient" means a load above zero; a crew that needs material and holds none
  acquires the storages of its material as its target scope (c10), not tasks.
- c7 also fires when a crew reaches a storage that is already empty.
- c10 also re-acquires when the construction state changed since the crew's task scope was
  set (a target vanished or appeared); a crew idle for want of targets waits for such a change.
- A deregistered crew that reaches the outlet leaves the plane (``leave_through_outlet``).
- A crew away from the plane (an absence, ``disruptions``) tries no row until it is back.
- c10 offers a crew only the queued tasks whose work points it reaches now: on a floor with
  decks (``Component.deck``, walked on once laid) a task behind decks not yet laid waits as
  for a predecessor (``Site.reachable``); c9 lays the deck its task lays (``Site.lay``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from . import construct, events, precedence
from .cases.reach import in_area
from .physics import Physics
from .precedence import QUEUE, WAIT
from .state import (
    DEREGISTERED,
    FETCHING,
    LEFT,
    NO_SCOPE,
    OUTLET,
    PAUSED,
    REACHING,
    STORAGES,
    TASKING,
    TASKS,
    WAITING,
    CraneRequest,
    CrewState,
    CrewStatus,
    IdleCause,
    ScopeKind,
    Site,
)
from .streams import RandomStreams

MAX_ROWS_PER_STEP = 3
EPS = construct.EPS


@dataclass
class Context:
    """What the rows read and change besides the crew: the site, the world, positions."""

    site: Site
    world: Physics
    positions: list
    streams: RandomStreams  # a task's pace comes from its own stream
    log: events.EventLog
    reached: dict = field(default_factory=dict)  # crew index -> target index reached, or -1
    reached_value: dict = field(default_factory=dict)  # crew index -> V_Tar of a reach
    # crew index -> ``site.version`` when the table last found no row but c2 to fire for the
    # crew (``apply_decision_table``), for ``only_execution_fires`` right after the table
    settled: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Row:
    """A row of Table 1: its code, the paper's wording, its trigger and its effect."""

    code: str  # "c1" ... "c10", Table 1
    name: str  # the paper's wording
    trigger: Callable[[CrewState, Context], bool]
    effect: Callable[[CrewState, Context], None]
    statuses: tuple[CrewStatus, ...]  # the crew states its trigger can hold in (an index only)


# -- what the triggers read -------------------------------------------------------------------

def reached_target(crew: CrewState, ctx: Context) -> int:
    """The target of the crew's scope whose region contains the crew's centre, or -1.

    A component is reached inside its task area (the component grown by the task type's area
    distance); a storage inside its area; the outlet within its radius. The area test is the
    reach rule's (``cases.reach.in_area``), the one the case check proves each task by.
    """
    if crew.index in ctx.reached:
        return ctx.reached[crew.index]
    site, hit = ctx.site, -1
    x, y = ctx.positions[crew.index]
    if crew.scope_kind in (TASKS, PAUSED):
        for target, task in crew.scope.items():
            if in_area(x, y, site.tasks[task].area):
                hit = target
                break
    elif crew.scope_kind == STORAGES:
        for target in crew.scope:
            if in_area(x, y, site.storages[target - len(site.components)].rect):
                hit = target
                break
    elif crew.scope_kind == OUTLET:
        plane = site.case.plane
        if math.hypot(x - plane.outlet_x_m, y - plane.outlet_y_m) <= plane.outlet_radius_m:
            hit = site.outlet_target
    ctx.reached[crew.index] = hit
    return hit


def _reached_storage(crew: CrewState, ctx: Context):
    if crew.status != REACHING or crew.scope_kind != STORAGES:
        return None
    target = reached_target(crew, ctx)
    return None if target < 0 else ctx.site.storages[target - len(ctx.site.components)]


def _task(crew: CrewState, ctx: Context):
    return ctx.site.tasks[crew.task]


def _record_reach(crew: CrewState, ctx: Context, target: int) -> None:
    ctx.reached_value[crew.index] = crew.values.get(target, 0.0)
    crew.stats.reaches += 1
    crew.steps_since_reach = 0
    ctx.log.add(ctx.site.time_s, "reach", crew.id, target_id(ctx.site, target),
                f"{crew.values.get(target, 0.0):.4f}")


def target_id(site: Site, target: int) -> str:
    n_comp = len(site.components)
    if target < n_comp:
        return site.components[target].id
    if target < n_comp + len(site.storages):
        return site.storages[target - n_comp].id
    return "outlet"


# -- c1 Initiate task -------------------------------------------------------------------------

def reached_task_target_with_equipment(crew: CrewState, ctx: Context) -> bool:
    if crew.status != REACHING or crew.scope_kind != TASKS \
            or crew.scope_version != ctx.site.version:
        return False
    target = reached_target(crew, ctx)
    if target < 0:
        return False
    task = ctx.site.tasks[crew.scope[target]]
    return ctx.site.executable(task) and construct.material_sufficient(crew, task)


def initiate_task(crew: CrewState, ctx: Context) -> None:
    site, target = ctx.site, reached_target(crew, ctx)
    task = site.tasks[crew.scope[target]]
    _record_reach(crew, ctx, target)
    precedence.start(site, task)
    ctx.world.add_task_area(task.index, task.area)
    task.crew = crew.index
    task.pace = construct.draw_pace(ctx.streams.pace(task.index), crew, task)
    task.crane_assisted = site.stage == 1  # section 4.2: no crane wait in stage 1
    crew.task = task.index
    crew.clear_scope()
    ctx.log.add(site.time_s, "task_start", crew.id, task.id)
    events.set_status(site, ctx.log, crew, TASKING)


# -- c2 Execute task --------------------------------------------------------------------------

def tasking_with_equipment_and_material(crew: CrewState, ctx: Context) -> bool:
    if crew.status != TASKING:
        return False
    task = ctx.site.tasks[crew.task]
    return (task.progress < task.work - EPS and construct.crane_ready(task)
            and construct.material_sufficient(crew, task))


def execute_task(crew: CrewState, ctx: Context) -> None:
    """The task progresses in P_cons (``construct.advance``) at the crew's drawn pace."""


# -- c3 Pause task ----------------------------------------------------------------------------

def tasking_with_material_running_out(crew: CrewState, ctx: Context) -> bool:
    if crew.status != TASKING:
        return False
    task = ctx.site.tasks[crew.task]
    return task.progress < task.work - EPS and not construct.material_sufficient(crew, task)


def pause_task(crew: CrewState, ctx: Context) -> None:
    crew.paused = True
    # A crew knows where it left its work (the target memory, when the case has it, tells it)
    task = _task(crew, ctx)
    crew.sightings[task.component] = (*ctx.positions[crew.index], ctx.site.time_s)
    ctx.log.add(ctx.site.time_s, "task_pause", crew.id, _task(crew, ctx).id)
    set_storage_scope(crew, ctx.site)
    events.set_status(ctx.site, ctx.log, crew, REACHING)


def set_storage_scope(crew: CrewState, site: Site) -> None:
    crew.clear_scope()
    crew.scope_kind = STORAGES
    crew.scope = {s.target: -1 for s in site.storages if s.material == crew.material}
    crew.scope_version = site.version


# -- c4 Resume task ---------------------------------------------------------------------------

def reached_paused_task(crew: CrewState, ctx: Context) -> bool:
    return (crew.status == REACHING and crew.scope_kind == PAUSED
            and reached_target(crew, ctx) >= 0)


def resume_task(crew: CrewState, ctx: Context) -> None:
    _record_reach(crew, ctx, reached_target(crew, ctx))
    crew.paused = False
    crew.clear_scope()
    ctx.log.add(ctx.site.time_s, "task_resume", crew.id, _task(crew, ctx).id)
    events.set_status(ctx.site, ctx.log, crew, TASKING)


# -- c5 Fetch materials -----------------------------------------------------------------------

def reached_storage_with_stock(crew: CrewState, ctx: Context) -> bool:
    storage = _reached_storage(crew, ctx)
    return storage is not None and storage.stock > EPS


def fetch_materials(crew: CrewState, ctx: Context) -> None:
    storage = _reached_storage(crew, ctx)
    _record_reach(crew, ctx, storage.target)
    crew.storage = storage.index
    crew.stats.material_trips += 1
    crew.clear_scope()
    events.set_status(ctx.site, ctx.log, crew, FETCHING)


# -- c6 Fetching completed --------------------------------------------------------------------

def fetching_at_full_load(crew: CrewState, ctx: Context) -> bool:
    return crew.status == FETCHING and crew.load >= crew.capacity - EPS


def complete_fetching(crew: CrewState, ctx: Context) -> None:
    crew.storage = -1
    if crew.paused:
        task = _task(crew, ctx)
        crew.scope_kind = PAUSED
        crew.scope = {task.component: task.index}
        crew.scope_version = ctx.site.version
    events.set_status(ctx.site, ctx.log, crew, REACHING)


# -- c7 Request crane for material ------------------------------------------------------------

def storage_running_out(crew: CrewState, ctx: Context) -> bool:
    if crew.status == FETCHING:
        return crew.load < crew.capacity - EPS and \
            ctx.site.storages[crew.storage].stock <= EPS
    storage = _reached_storage(crew, ctx)
    return storage is not None and storage.stock <= EPS


def request_crane_for_material(crew: CrewState, ctx: Context) -> None:
    if crew.status == REACHING:
        storage = _reached_storage(crew, ctx)
        _record_reach(crew, ctx, storage.target)
        crew.storage = storage.index
        crew.stats.material_trips += 1
        crew.clear_scope()
    storage = ctx.site.storages[crew.storage]
    if not storage.lift_pending:  # one lift serves every crew waiting at this storage
        storage.lift_pending = True
        construct.request_crane(ctx.site, ctx.log, CraneRequest(
            crew.index, "material", storage=storage.index))
    crew.stats.crane_waits += 1
    events.set_status(ctx.site, ctx.log, crew, WAITING)


# -- c8 Request crane for task ----------------------------------------------------------------

def started_crane_task_with_material(crew: CrewState, ctx: Context) -> bool:
    if crew.status != TASKING:
        return False
    task = ctx.site.tasks[crew.task]
    return (task.progress < task.work - EPS and not construct.crane_ready(task)
            and construct.material_sufficient(crew, task))


def request_crane_for_task(crew: CrewState, ctx: Context) -> None:
    construct.request_crane(ctx.site, ctx.log, CraneRequest(crew.index, "task", task=crew.task))
    crew.stats.crane_waits += 1
    events.set_status(ctx.site, ctx.log, crew, WAITING)


# -- c9 Complete task -------------------------------------------------------------------------

def tasking_with_progress_complete(crew: CrewState, ctx: Context) -> bool:
    if crew.status != TASKING:
        return False
    task = ctx.site.tasks[crew.task]
    return task.progress >= task.work - EPS


def complete_task(crew: CrewState, ctx: Context) -> None:
    task = _task(crew, ctx)
    task.progress = task.work
    precedence.finish(ctx.site, task)
    ctx.world.remove_task_area(task.index)
    deck = ctx.site.lay(task)
    if deck >= 0:  # a deck laid: crews walk over it from now on
        ctx.world.lay_deck(deck)
    crew.task = -1
    crew.clear_scope()
    ctx.log.add(ctx.site.time_s, "task_finish", crew.id, task.id)
    events.set_status(ctx.site, ctx.log, crew, REACHING)


# -- c10 Acquire target -----------------------------------------------------------------------

def reaching_without_current_scope(crew: CrewState, ctx: Context) -> bool:
    return (crew.status == REACHING and not crew.paused
            and crew.scope_kind in (NO_SCOPE, TASKS)
            and crew.scope_version != ctx.site.version)


def acquire_target(crew: CrewState, ctx: Context) -> None:
    """Scope: components with executable tasks of its type; storages if it holds no material;
    the outlet (and deregistration) when no task of its type is queued or waiting."""
    site = ctx.site
    queued, waiting, executable = _pools_of_type(site, crew.type)
    if not queued and not waiting:
        crew.clear_scope()
        crew.scope_kind = OUTLET
        crew.scope = {site.outlet_target: -1}
        crew.scope_version = site.version
        crew.idle_cause = IdleCause.NONE
        events.set_status(site, ctx.log, crew, DEREGISTERED)
        return
    if crew.material is not None and crew.load <= EPS:
        set_storage_scope(crew, site)
        crew.idle_cause = IdleCause.NONE
        return
    # each queued task's space conflicts looked at once (the scope, then the idle cause); a
    # task whose work point the crew cannot reach yet (behind decks not laid) waits as for a
    # predecessor, or the crew would walk for it forever
    if site.reach is not None:
        queued = [t for t in queued if site.reachable(crew, t)]
        executable = [t for t in queued if site.executable(t)]
    scope = {t.component: t.index for t in executable}
    if scope.keys() != crew.scope.keys() or crew.scope_kind != TASKS:
        crew.values = {}  # new targets: the evaluator values them this step
    crew.scope_kind = TASKS if scope else NO_SCOPE
    crew.scope = scope
    crew.scope_version = site.version
    if scope:
        crew.idle_cause = IdleCause.NONE
    elif queued:  # some queued task is not executable: blocked by an area
        crew.idle_cause = IdleCause.AREA if len(executable) < len(queued) \
            else IdleCause.NO_TARGET
    else:
        crew.idle_cause = IdleCause.PREDECESSOR


def _pools_of_type(site: Site, crew_type: str) -> tuple[list, bool, list]:
    """A crew type's tasks not yet started: those queued (in order), whether any waits, and
    the queued ones executable now (``Site.executable``). Pools and task areas change only
    with ``site.version``, so they are worked out once per type and version (every crew of
    the type asks at every c10)."""
    held = site.pools_by_type.get(crew_type)
    if held is not None and held[0] == site.version:
        return held[1], held[2], held[3]
    tasks = site.tasks
    queued, waiting = [], False
    for i in site.tasks_of_crew_type[crew_type]:  # one pass
        pool = tasks[i].pool
        if pool == QUEUE:
            queued.append(tasks[i])
        elif pool == WAIT:
            waiting = True
    executable = [t for t in queued if site.executable(t)]
    site.pools_by_type[crew_type] = (site.version, queued, waiting, executable)
    return queued, waiting, executable


_T, _F, _R = (TASKING,), (FETCHING,), (REACHING,)
DECISION_TABLE: tuple[Row, ...] = (
    Row("c9", "Complete task", tasking_with_progress_complete, complete_task, _T),
    Row("c3", "Pause task", tasking_with_material_running_out, pause_task, _T),
    Row("c8", "Request crane for task", started_crane_task_with_material,
         request_crane_for_task, _T),
    Row("c2", "Execute task", tasking_with_equipment_and_material, execute_task, _T),
    Row("c6", "Fetching completed", fetching_at_full_load, complete_fetching, _F),
    Row("c7", "Request crane for material", storage_running_out, request_crane_for_material,
         _F + _R),
    Row("c5", "Fetch materials", reached_storage_with_stock, fetch_materials, _R),
    Row("c4", "Resume task", reached_paused_task, resume_task, _R),
    Row("c1", "Initiate task", reached_task_target_with_equipment, initiate_task, _R),
    Row("c10", "Acquire target", reaching_without_current_scope, acquire_target, _R),
)
TERMINAL_ROWS = {"c2", "c10"}  # rows after which no other row fires in the same step
# The table's rows per crew state, in table order: a waiting or deregistered crew tries none.
ROWS_BY_STATUS = {s: tuple(r for r in DECISION_TABLE if s in r.statuses) for s in CrewStatus}
# A reaching crew's rows by its scope kind as well: their triggers read the kind first (c7 and
# c5 a storage scope, c4 a paused task, c1 tasks, c10 tasks or none), so the others cannot
# fire; the rows are tried for every crew at every event. Other states read no scope kind.
_REACHING_KINDS = {"c7": (STORAGES,), "c5": (STORAGES,), "c4": (PAUSED,), "c1": (TASKS,),
                   "c10": (NO_SCOPE, TASKS)}
ROWS_BY_STATE = {(s, k): tuple(r for r in rows if s != REACHING
                               or k in _REACHING_KINDS.get(r.code, ScopeKind))
                 for s, rows in ROWS_BY_STATUS.items() for k in ScopeKind}
# ... without c2 (``only_execution_fires``)
_ROWS_BUT_EXECUTION = {state: tuple(r for r in rows if r.code != "c2")
                       for state, rows in ROWS_BY_STATE.items()}


def first_rule(crew: CrewState, ctx: Context) -> Row | None:
    for rule in ROWS_BY_STATE[crew.status, crew.scope_kind]:
        if rule.trigger(crew, ctx):
            return rule
    return None


# each state's last row: c2 firing first, when it is the last, means no other row fires
_LAST_ROW = {s: rows[-1] for s, rows in ROWS_BY_STATUS.items() if rows}
_EXECUTION = next(r for r in DECISION_TABLE if r.code == "c2")  # the last of its states' rows


def _only_execution(crew: CrewState, task) -> bool:
    """A tasking crew's rows at once: c9 (its task is not done), c3 (material left), c8 (the
    crane ready or not needed) fail and c2 fires; ``DECISION_TABLE``'s triggers in one read
    (a test holds the two equal on every tasking state)."""
    return (task.progress < task.work - EPS
            and (task.material_per_work == 0.0 or crew.load > EPS)
            and (not task.needs_crane or task.crane_assisted))


def only_execution_fires(ctx: Context, settled: dict | None = None) -> bool:
    """True when, for every crew, no row but c2 (execute) would fire: a quiet second.

    ``settled``: the ``Context.settled`` of a table run on the same state, nothing changed
    since but values, walks and disruption causes (the event floor's next event, asked right
    after its table). A crew the table settled at the site's version now is skipped: another
    crew's rows change what a crew's triggers read only through pools and task areas, which
    bump the version; its own state has not changed since."""
    version = ctx.site.version
    for crew in ctx.site.crews:
        if crew.absent:
            continue
        if settled is not None and settled.get(crew.index) == version:
            continue
        if crew.status == TASKING and _only_execution(crew, ctx.site.tasks[crew.task]):
            continue
        for rule in _ROWS_BUT_EXECUTION[crew.status, crew.scope_kind]:
            if rule.trigger(crew, ctx):
                return False
    return True


def apply_decision_table(ctx: Context) -> dict[int, list[str]]:
    """Fire the table for every crew on the plane; returns the codes fired per crew."""
    fired: dict[int, list[str]] = {}
    site, settled, reached = ctx.site, ctx.settled, ctx.reached
    tasks, version = site.tasks, site.version
    for crew in site.crews:
        status = crew.status
        if status == LEFT or crew.absent:  # away (a disruption): no decisions
            continue
        if status == TASKING and _only_execution(crew, tasks[crew.task]):
            # most crews at most steps: c9, c3 and c8 fail and c2 fires (the rows' own
            # triggers, read at once; c2's effect is P_cons' and nothing else fires after it)
            settled[crew.index] = version
            reached.pop(crew.index, None)
            fired[crew.index] = ["c2"]
            continue
        codes = []
        for _ in range(MAX_ROWS_PER_STEP):
            for rule in ROWS_BY_STATE[crew.status, crew.scope_kind]:  # ``first_rule``
                if rule.trigger(crew, ctx):
                    break
            else:  # no row fires
                settled[crew.index] = site.version
                break
            if rule is _EXECUTION:  # c2, its state's last row: no other row fires
                settled[crew.index] = site.version
            rule.effect(crew, ctx)
            reached.pop(crew.index, None)
            codes.append(rule.code)
            if rule.code in TERMINAL_ROWS:
                break
        if crew.status == DEREGISTERED:
            leave_through_outlet(crew, ctx)
        fired[crew.index] = codes
    return fired


def leave_through_outlet(crew: CrewState, ctx: Context) -> None:
    """The end of c10's deregistration: a crew at the outlet leaves the plane."""
    if reached_target(crew, ctx) == ctx.site.outlet_target:
        _record_reach(crew, ctx, ctx.site.outlet_target)
        crew.clear_scope()
        ctx.world.remove_crew(crew.index)
        events.set_status(ctx.site, ctx.log, crew, LEFT)
    ctx.reached.pop(crew.index, None)


def table_as_markdown() -> str:
    """The docs' copy of Table 1, printed from the code."""
    lines = ["| order | code | name | trigger | effect |", "|---|---|---|---|---|"]
    for i, rule in enumerate(DECISION_TABLE, 1):
        lines.append(f"| {i} | {rule.code} | {rule.name} | `{rule.trigger.__name__}` | "
                     f"`{rule.effect.__name__}` |")
    return "\n".join(lines)
