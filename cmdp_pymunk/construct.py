"""P_cons: task progress, material fetching and the crane, with invading crews (Eq. 2).

Efficiencies are drawn from Table 3 when a task is initiated, from the task's own random
stream (``streams``: keyed by seed and task, so strategies on one seed meet the same paces):
one draw per task, a crew's pace on a task is one realisation; drawing every second would
average Table 3's spread away.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

import numpy as np

from . import events
from .state import (
    FETCHING,
    LEFT,
    TASKING,
    WAITING,
    CraneRequest,
    CrewState,
    Rect,
    Site,
    StorageState,
    TaskState,
    inside,
)

EPS = 1e-9
MIN_PACE_SHARE = 0.1  # a draw below 10 % of the mean is clipped there: no crew stands still


def invaded_efficiency(nominal: float, invasion: float) -> float:
    """Efficiency with invading crews, Eq. (2): e_t = max(0, e * (1 - n * I_agent)).

    Args:
        nominal: e_i, the nominal task or material-acquisition efficiency (any unit per s).
        invasion: n * I_agent, the number of invaders times their inefficiency index; with
            invaders of different types, the sum of their indices.
    """
    return max(0.0, nominal * (1.0 - invasion))


def invasion(site: Site, positions, crew: CrewState, area: Rect) -> float:
    """n * I_agent for the area a crew works in: the indices of the other crews inside it."""
    total = 0.0
    for other in site.crews:
        if other is not crew and other.status != LEFT:
            x, y = positions[other.index]
            if inside(x, y, area):
                total += other.spec.invasion_index
    return total


def draw_pace(rng: np.random.Generator, crew: CrewState, task: TaskState) -> float:
    """Work per second on this task, drawn from Table 3 (normal, clipped at 10 % of the mean)."""
    return pace_of(rng, crew.spec)


def pace_of(rng: np.random.Generator, spec) -> float:
    """Work per second drawn for a crew type ``spec`` (``CrewType``) from Table 3: a duration
    crew draws minutes per unit of work, an efficiency crew work per minute, each a normal
    clipped below at 10 % of its mean. One function, so ``bounds.seed_lower_bound`` reads the
    paces a floor will draw without running it."""
    if spec.by_duration:
        mean, sd = spec.duration_mean_min, spec.duration_sd_min or 0.0
        minutes = max(rng.normal(mean, sd), MIN_PACE_SHARE * mean)
        return 1.0 / (minutes * 60.0)  # one unit of work per drawn duration (CrewType doc)
    mean, sd = spec.efficiency_mean_per_min, spec.efficiency_sd_per_min or 0.0
    return max(rng.normal(mean, sd), MIN_PACE_SHARE * mean) / 60.0


def material_sufficient(crew: CrewState, task: TaskState) -> bool:
    return task.material_per_work == 0.0 or crew.load > EPS


def crane_ready(task: TaskState) -> bool:
    return not task.needs_crane or task.crane_assisted


def advance(site: Site, positions, log: events.EventLog, dt: float,
            invasion_of: Callable[[Site, list, CrewState, Rect], float] | None = None,
            logistics: LiftQuestion | None = None) -> None:
    """One step of P_cons for every crew that tasks or fetches, then the crane. A weather
    stop halts all of it; an absent crew does nothing (``site.disrupted``, ``disruptions``).

    ``invasion_of(site, positions, crew, area)``: Eq. 2's n * I_agent for a crew working or
    fetching in ``area``; default ``invasion``, the crews standing in it now. The event floor
    (``cmdp_pymunk.eventfloor``), whose crews are not on the plane between events, passes its
    calibrated expectation and steps ``dt`` of many seconds between events: every rate is
    constant within such a step, so one step of ``dt`` is ``dt`` steps of one second.

    ``logistics``: the logistics role's question (``LiftQuestion``; the engine's
    ``logistics.Logistics`` bound to it): a crew that fetches asks it whether to ask for the
    next lift now at each decision level its storage reaches (``consider_lift``); None: the
    case's reorder point decides (``reorder``)."""
    now = site.disrupted
    disrupted = bool(now)  # once, not per crew
    invaded = invasion if invasion_of is None else invasion_of
    fetching = []
    for crew in site.crews:
        if disrupted and (now.weather or crew.absent):
            continue
        if crew.status == TASKING:
            _work(site, positions, crew, dt, invaded)
        elif crew.status == FETCHING:
            _fetch(site, positions, crew, dt, invaded)
            fetching.append(crew)
    if not (now and now.crane_stopped()):  # broken down or weather: its queue waits
        _serve_crane(site, log, dt)
    # after the crane's step: a lift asked for at the end of this step starts counting down in
    # the next, on the pymunk floor (dt 1) and on the event floor (dt many seconds) alike
    if logistics is None:
        for crew in fetching:
            reorder(site, log, crew)
    else:
        for crew in fetching:
            consider_lift(site, log, crew, logistics)


def next_change_in(site: Site, positions, invasion_of=invasion,
                   levels: Callable[[str], tuple[float, ...]] | None = None) -> float:
    """Seconds (not rounded) until P_cons next changes anything a rule reads, with every rate
    held as it is now (what the event floor jumps by; inf: nothing of P_cons will change).
    One term per rule, each beside the rule it times: a task ends or its crew's load runs out
    (``_work_left_s``), a load is full (``_fetch_left_s``), a storage is empty or down to its
    reorder point (``_stock_left_s``) or, with a logistics role (``levels``, its
    ``Logistics.levels``), to its next decision level (``_level_left_s``), the crane's lift or
    assistance is done (``_crane_left_s``). A weather stop halts every rate but the crane's
    stop."""
    now = site.disrupted
    weather = bool(now) and now.weather
    soonest = _crane_left_s(site)
    if weather:
        return soonest
    drain: dict[int, float] = {}  # storage -> loading rate of the crews at it
    for crew in site.crews:
        if crew.absent:
            continue
        if crew.status == TASKING:
            soonest = min(soonest, _work_left_s(site, positions, crew, invasion_of))
        elif crew.status == FETCHING:
            left, rate = _fetch_left_s(site, positions, crew, invasion_of)
            if rate > 0.0:
                soonest = min(soonest, left)
                drain[crew.storage] = drain.get(crew.storage, 0.0) + rate
    for s, rate in drain.items():
        storage = site.storages[s]
        soonest = min(soonest, _stock_left_s(site, storage, rate, levels is None))
        if levels is not None:
            soonest = min(soonest, _level_left_s(storage, rate, levels(storage.material)))
    return soonest


def _work_left_s(site: Site, positions, crew: CrewState, invaded) -> float:
    """Seconds until the crew's task ends or its load runs out (``_work``'s rates)."""
    task = site.tasks[crew.task]
    if not (crane_ready(task) and material_sufficient(crew, task)) or \
            task.progress >= task.work - EPS:
        return math.inf
    rate = invaded_efficiency(task.pace, invaded(site, positions, crew, task.area))
    if rate <= 0.0:
        return math.inf
    left = (task.work - task.progress) / rate
    if task.material_per_work > 0.0:
        left = min(left, crew.load / (task.material_per_work * rate))
    return left


def _work(site: Site, positions, crew: CrewState, dt: float, invaded=invasion) -> None:
    task = site.tasks[crew.task]
    if not crane_ready(task) or not material_sufficient(crew, task):
        return
    remaining = task.work - task.progress
    if site.stage == 1:  # section 4.2: no task durations (the crew's load is still used up)
        amount = remaining
    else:
        amount = min(remaining, invaded_efficiency(task.pace, invaded(
            site, positions, crew, task.area)) * dt)
    if task.material_per_work > 0.0:
        amount = min(amount, crew.load / task.material_per_work)
        crew.load = max(0.0, crew.load - amount * task.material_per_work)
    task.progress += amount


def _fetch(site: Site, positions, crew: CrewState, dt: float, invaded=invasion) -> None:
    storage = site.storages[crew.storage]
    if site.stage == 1:  # section 5.2: unrestricted stockpiles, no durations: load up at once
        crew.load = crew.capacity
        return
    rate = site.case.materials[storage.material].acquire_per_min / 60.0
    amount = min(invaded_efficiency(rate, invaded(site, positions, crew, storage.rect)) * dt,
                 storage.stock, crew.capacity - crew.load)
    crew.load += amount
    storage.stock -= amount


def _fetch_left_s(site: Site, positions, crew: CrewState, invaded) -> tuple[float, float]:
    """Seconds until the crew's load is full, and its loading rate (``_fetch``'s)."""
    storage = site.storages[crew.storage]
    rate = invaded_efficiency(site.case.materials[storage.material].acquire_per_min / 60.0,
                              invaded(site, positions, crew, storage.rect))
    if rate <= 0.0:
        return math.inf, 0.0
    return (crew.capacity - crew.load) / rate, rate


def _stock_left_s(site: Site, storage: StorageState, rate: float,
                  reorder_point: bool = True) -> float:
    """Seconds until a storage drawn at ``rate`` is empty (c7), or down to its material's
    reorder point with no lift asked for (``reorder_due``; not with ``reorder_point`` False:
    a logistics role decides instead)."""
    left = storage.stock / rate
    at = site.case.materials[storage.material].reorder_at if reorder_point else 0.0
    if at > 0.0 and not storage.lift_pending and storage.stock > at + EPS:
        left = min(left, (storage.stock - at) / rate)
    return left


def reorder_due(site: Site, storage: StorageState) -> bool:
    """A storage's stock has fallen to its material's reorder point (``Material.reorder_at``,
    above 0) with stock left and no lift asked for yet: the fetching crew asks for one now
    and goes on loading, instead of finding the storage empty and waiting (c7)."""
    at = site.case.materials[storage.material].reorder_at
    return at > 0.0 and not storage.lift_pending and EPS < storage.stock <= at + EPS


def reorder(site: Site, log: events.EventLog, crew: CrewState) -> None:
    """Ask the crane for a storage's next lift on the fetching ``crew``'s behalf when the
    storage reached its reorder point (``reorder_due``); the crew keeps fetching. When the
    stock runs out before the lift lands, c7 finds the lift pending and the crew waits for it
    as for any lift."""
    storage = site.storages[crew.storage]
    if reorder_due(site, storage):
        order_lift(site, log, crew, storage)


class LiftQuestion(Protocol):
    """What ``advance`` asks of the logistics role (``logistics.Logistics`` bound to an
    engine): the decision levels of a material, and whether to ask for the next lift now."""

    def levels(self, material: str) -> tuple[float, ...]:
        """Stock levels (in the material's unit) at which a crew fetching it asks."""

    def lift_now(self, crew: int, storage: int) -> bool:
        """Whether crew ``crew``, fetching at ``storage``, asks for the next lift now."""


def decision_level(storage: StorageState, levels: tuple[float, ...]) -> float | None:
    """The decision level a storage's stock has reached, if the logistics role was not asked
    there yet since the storage's last lift landed (``StorageState.asked_at``): the lowest of
    ``levels`` at or above the stock, with stock left and no lift asked for; None: no
    decision is due. A jump past several levels asks once, at the lowest."""
    if storage.lift_pending or storage.stock <= EPS:
        return None
    due = [level for level in levels
           if storage.stock <= level + EPS and level < storage.asked_at]
    return min(due) if due else None


def consider_lift(site: Site, log: events.EventLog, crew: CrewState,
                  logistics: LiftQuestion) -> None:
    """The fetching ``crew``'s logistics decision: when its storage's stock has reached a
    decision level (``decision_level``), the role is asked once there whether to ask for the
    next lift now (``order_lift``); otherwise the storage runs on towards the next level or
    empty (c7). With one level per material and "yes" always, this is ``reorder``."""
    storage = site.storages[crew.storage]
    level = decision_level(storage, logistics.levels(storage.material))
    if level is None:
        return
    storage.asked_at = level
    if logistics.lift_now(crew.index, storage.index):
        order_lift(site, log, crew, storage)


def _level_left_s(storage: StorageState, rate: float, levels: tuple[float, ...]) -> float:
    """Seconds until a storage drawn at ``rate`` is down to its next decision level not yet
    asked at (``decision_level``): where the event floor stops for the logistics role."""
    if storage.lift_pending:
        return math.inf
    stock, left = storage.stock, math.inf
    for level in levels:
        if level < storage.asked_at and stock > level + EPS:
            left = min(left, (stock - level) / rate)
    return left


def order_lift(site: Site, log: events.EventLog, crew: CrewState,
               storage: StorageState) -> None:
    """Ask the crane for ``storage``'s next lift on the fetching ``crew``'s behalf, before the
    storage is empty (a reorder point's or the logistics role's request); the crew keeps
    fetching."""
    storage.lift_pending = True
    request_crane(site, log, CraneRequest(crew.index, "material", storage=storage.index))


def request_crane(site: Site, log: events.EventLog, request: CraneRequest) -> None:
    site.crane.queue.append(request)
    log.add(site.time_s, "crane_request", site.crews[request.crew].id,
            site.tasks[request.task].id if request.task >= 0 else
            site.storages[request.storage].id, request.kind)
    if site.crane.current is None:  # an idle crane sets off now: a lift takes lift_time_s
        start_next(site)


def start_next(site: Site) -> None:
    """The crane takes up its next request, first come, first served; with disruptions
    (``site.disrupted``), none while it is stopped, and not a lift whose delivery is late
    (the requests behind it go first)."""
    crane = site.crane
    now = site.disrupted
    if not now:
        crane.current = crane.queue.popleft()
    elif now.crane_stopped():
        return
    else:
        ready = [k for k, r in enumerate(crane.queue)
                 if not (r.kind == "material" and r.storage in now.late)]
        if not ready:
            return
        crane.current = crane.queue[ready[0]]
        del crane.queue[ready[0]]
    cfg = site.case.crane
    crane.remaining_s = cfg.lift_time_s if crane.current.kind == "material" \
        else cfg.assist_time_s


def _crane_left_s(site: Site) -> float:
    """Seconds until the crane's lift or assistance under way is done (``_serve_crane``);
    inf with none under way or the crane stopped."""
    crane, now = site.crane, site.disrupted
    if crane.current is None or (now and now.crane_stopped()):
        return math.inf
    return crane.remaining_s


def _serve_crane(site: Site, log: events.EventLog, dt: float) -> None:
    crane = site.crane
    if crane.current is not None:
        crane.remaining_s -= dt
        if crane.remaining_s <= EPS:
            _complete(site, log, crane.current)
            crane.current = None
    if crane.current is None and crane.queue:
        start_next(site)


def _complete(site: Site, log: events.EventLog, request: CraneRequest) -> None:
    """The lifted material arrives at its storage, or the hoisting assistance arrives."""
    if request.kind == "material":
        storage: StorageState = site.storages[request.storage]
        lift = site.case.materials[storage.material].crane_lift_quantity
        storage.stock = min(storage.capacity, storage.stock + lift)
        storage.lift_pending = False
        storage.asked_at = math.inf  # the logistics role is asked at every level again
        log.add(site.time_s, "crane_done", site.crews[request.crew].id, storage.id, "material")
        for crew in site.crews:
            # a crew waiting for a lift holds its storage; one waiting for hoisting holds none
            if crew.status == WAITING and crew.storage == storage.index:
                events.set_status(site, log, crew, FETCHING)
    else:
        task = site.tasks[request.task]
        task.crane_assisted = True
        crew = site.crews[request.crew]
        log.add(site.time_s, "crane_done", crew.id, task.id, "task")
        events.set_status(site, log, crew, TASKING)
