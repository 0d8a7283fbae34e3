"""The task flow wait -> queue -> on -> end (section 3.5), driven by precedence."""

from __future__ import annotations

from enum import IntEnum
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the site imports the pools from here, not the other way round
    from .state import Site, TaskState


class Pool(IntEnum):
    """The four task pools of section 3.5."""

    WAIT = 0
    QUEUE = 1
    ON = 2
    END = 3


# The pools as module names, for code that runs at every step (``state`` says why).
WAIT, QUEUE, ON, END = Pool.WAIT, Pool.QUEUE, Pool.ON, Pool.END


def initial_pools(site: Site) -> None:
    """Every task unstarted (section 5.1): in the queue if it has no predecessor, else waiting."""
    for task in site.tasks:
        task.pool = Pool.QUEUE if not task.predecessors else Pool.WAIT
    site.version += 1


def start(site: Site, task: TaskState) -> None:
    """queue -> on: the task is initiated and its area goes onto the plane."""
    assert task.pool == Pool.QUEUE, f"{task.id} started from {task.pool.name}"
    task.pool = Pool.ON
    task.started_s = site.time_s
    site.active_areas.append(task.index)
    site.version += 1


def finish(site: Site, task: TaskState) -> list[TaskState]:
    """on -> end; successors whose predecessors have all ended move wait -> queue.

    Returns the successors released to the queue.
    """
    assert task.pool == Pool.ON, f"{task.id} finished from {task.pool.name}"
    task.pool = Pool.END
    task.ended_s = site.time_s
    site.active_areas.remove(task.index)
    site.tasks_ended += 1
    released = []
    for s in task.successors:
        succ = site.tasks[s]
        if succ.pool == Pool.WAIT and all(
                site.tasks[p].pool == Pool.END for p in succ.predecessors):
            succ.pool = Pool.QUEUE
            released.append(succ)
    site.version += 1
    return released


def component_attributes(site: Site, component: int) -> tuple[tuple[str, ...], str | None]:
    """The component's projected attributes (section 3.5): its executable task types (queue)
    and its performing task type (on), which is what rays see of the construction state."""
    executable, performing = [], None
    for t in site.components[component].tasks:
        task = site.tasks[t]
        if task.pool == Pool.QUEUE:
            executable.append(task.type)
        elif task.pool == Pool.ON:
            performing = task.type
    return tuple(executable), performing
