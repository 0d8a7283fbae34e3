"""The 4D schedule an IFC model carries for a storey's elements, read for the IFC import.

Where the model carries a 4D schedule (IfcTask assigned to the storey's elements with
IfcRelAssignsToProduct, or the elements to the task with IfcRelAssignsToProcess;
IfcRelSequence between such tasks), its sequences replace the recipe's links between
components (``ifc_import.build_case``): a sequence A -> B makes the first task of B's chain on
each of B's elements wait for the last task of A's chain on each of A's elements (a task whose
Identification or Name holds a recipe task type as a word, e.g. "HI S-1", stands for that
task alone: :func:`_sequence_predecessors`). Chains within a component stay. The simulator's
precedences are finish-to-start: other sequence types and lags are reported and read as
finish-to-start.

Apart from the elements' geometry (``ifc_model``) and the case (``ifc_import``): it reads
tasks and their relations only, no geometry. :func:`task_code` is the 4D export's too
(``ifc_export.read_4d``).
"""

from __future__ import annotations

import graphlib
import re
from dataclasses import dataclass, field

from .floorplan import Recipe


@dataclass
class ModelSchedule:
    """The 4D schedule the model carries for the storey's elements: per IfcTask (by GlobalId)
    its name and the components it builds, and the sequences between such tasks."""

    tasks: dict[str, tuple[str, list[str], str | None]] = field(default_factory=dict)
    sequences: list[tuple[str, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def task_code(task) -> str:
    """A task's Identification (IFC4), or TaskId (IFC2X3), or ""."""
    return getattr(task, "Identification", None) or getattr(task, "TaskId", None) or ""


def _task_label(task) -> str:
    return f'IfcTask "{task.Name or task_code(task)}" ({task.GlobalId})'


def model_schedule(model, component_of: dict[str, str], recipe: Recipe) -> ModelSchedule:
    """The IfcTasks that build the components' elements (the task assigned to the element,
    IfcRelAssignsToProduct, or the element to the task, IfcRelAssignsToProcess) and the
    IfcRelSequence among them.

    A task whose Identification or Name holds one of the recipe's task types as a word
    (e.g. "HI S-1") stands for that task type only; None: for the whole chain."""
    types = recipe.task_types()
    schedule = ModelSchedule()
    # A task builds an element: the task assigned to the element (IfcRelAssignsToProduct, as
    # ifcopenshell.api and cmdp-simulate --ifc write it), or the element assigned to the task
    # as what it operates on (IfcRelAssignsToProcess, as some 4D tools write it)
    links = [(rel.RelatingProduct, task) for rel in model.by_type("IfcRelAssignsToProduct")
             for task in rel.RelatedObjects]
    links += [(product, rel.RelatingProcess) for rel in model.by_type("IfcRelAssignsToProcess")
              for product in rel.RelatedObjects]
    for product, task in links:
        comp = component_of.get(getattr(product, "GlobalId", None))
        if comp is None or not task.is_a("IfcTask"):
            continue
        words = re.split(r"[^A-Za-z0-9]+", f"{task_code(task)} {task.Name or ''}")
        step = next((w for w in words if w in types), None)
        label, comps, _ = schedule.tasks.get(task.GlobalId, (_task_label(task), [], step))
        if comp not in comps:
            schedule.tasks[task.GlobalId] = (label, [*comps, comp], step)
    for rel in model.by_type("IfcRelSequence"):
        a, b = rel.RelatingProcess.GlobalId, rel.RelatedProcess.GlobalId
        if a not in schedule.tasks or b not in schedule.tasks:
            continue
        kind = getattr(rel, "SequenceType", None) or "FINISH_START"
        if kind != "FINISH_START":
            schedule.notes.append(f"IfcRelSequence {rel.GlobalId} {schedule.tasks[a][0]} -> "
                                  f"{schedule.tasks[b][0]} is {kind}; read as FINISH_START")
        lag = getattr(rel, "TimeLag", None)
        if lag is not None and lag != 0:  # IFC2X3: a number (always given); IFC4: IfcLagTime
            schedule.notes.append(f"IfcRelSequence {rel.GlobalId}: its time lag is ignored")
        schedule.sequences.append((a, b))
    return schedule


def _schedule_cycle(schedule: ModelSchedule) -> list[str] | None:
    preds: dict[str, list[str]] = {t: [] for t in schedule.tasks}
    for a, b in schedule.sequences:
        preds[b].append(a)
    try:
        graphlib.TopologicalSorter(preds).prepare()
    except graphlib.CycleError as err:
        return list(err.args[1])
    return None


def _sequence_predecessors(schedule: ModelSchedule, chains: dict[str, list[str]],
                           task_types: dict[str, str]) -> dict[str, list[str]]:
    """Case task -> the case tasks it waits for, from the model's sequences."""

    def tasks_of(guid: str, end: bool) -> list[str]:
        _, comps, step = schedule.tasks[guid]
        out = []
        for comp in comps:
            chain = chains.get(comp, [])
            if step is not None:
                out += [t for t in chain if task_types[t] == step]
            elif chain:
                out.append(chain[-1] if end else chain[0])
        return out

    preds: dict[str, list[str]] = {}
    for a, b in schedule.sequences:
        for later in tasks_of(b, end=False):
            for earlier in tasks_of(a, end=True):
                if earlier != later and earlier not in preds.setdefault(later, []):
                    preds[later].append(earlier)
    return preds
