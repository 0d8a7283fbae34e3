"""Floors from BIM, the output side: a case as an IFC model, and a simulated schedule as 4D.

**Export** (``cmdp-simulate --ifc``, :func:`export_4d`). A copy of the model with an
IfcWorkSchedule holding one IfcTask per task of the case: IfcTaskTime with the simulated
start and finish (elapsed time from a given start date, or, with the case's working calendar,
its dates: ``workcalendar``), the crew that did it as
an IfcCrewResource assigned to it (IfcRelAssignsToProcess), the element it builds
(IfcRelAssignsToProduct) and the case's precedences as IfcRelSequence. IFC2X3 has no
IfcTaskTime: there the times are an IfcScheduleTimeControl, the TimeForTask of the
IfcRelAssignsTasks that puts the task in the schedule, written entity by entity
(:func:`_write_4d_ifc2x3`).

``model_from_case`` writes a case's components as an IFC4 model (the sample model and the
tests' models are made so). IfcOpenShell is an optional dependency, imported only when a
function here is called (``ifc_model.require_ifcopenshell``).
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

from .ifc_model import open_model, require_ifcopenshell
from .ifc_schedule import task_code
from .load import CaseError

# -- a case as a model -----------------------------------------------------------------------

def model_from_case(case, storey: str = "Level 1", origin: tuple[float, float] = (0.0, 0.0),
                    classes: dict[str, str] | None = None, seed: str = "cmdp"):
    """An IFC4 model of a case's components: one storey at z 0, each component its footprint
    (its rectangle, or its outline) extruded 0.3 m (IfcSlab for "precast", IfcBeam for
    "cast-in-place", by default; other kinds IfcBuildingElementProxy) named by its id, its
    box's centre at ``origin`` + the component's centre. GlobalIds are derived from ``seed``
    and the ids, and the header's time stamp is fixed, so one case gives one file byte for
    byte. The model's length unit is the millimetre, as BIM tools write; the importer reads
    metres back."""
    require_ifcopenshell()
    import uuid

    import ifcopenshell.api.aggregate
    import ifcopenshell.api.context
    import ifcopenshell.api.geometry
    import ifcopenshell.api.project
    import ifcopenshell.api.root
    import ifcopenshell.api.spatial
    import ifcopenshell.api.unit
    import ifcopenshell.guid
    import numpy as np

    api = ifcopenshell.api
    classes = classes or {"precast": "IfcSlab", "cast-in-place": "IfcBeam"}
    f = api.project.create_file(version="IFC4")
    made = []

    def entity(ifc_class: str, name: str):
        e = api.root.create_entity(f, ifc_class=ifc_class, name=name)
        e.GlobalId = ifcopenshell.guid.compress(uuid.uuid5(uuid.NAMESPACE_URL,
                                                           f"{seed}/{ifc_class}/{name}").hex)
        made.append(e)
        return e

    project = entity("IfcProject", case.case.name)
    api.unit.assign_unit(f)
    model = api.context.add_context(f, context_type="Model")
    body = api.context.add_context(f, context_type="Model", context_identifier="Body",
                                   target_view="MODEL_VIEW", parent=model)
    site, building = entity("IfcSite", "Site"), entity("IfcBuilding", "Building")
    level = entity("IfcBuildingStorey", storey)
    api.aggregate.assign_object(f, products=[site], relating_object=project)
    api.aggregate.assign_object(f, products=[building], relating_object=site)
    api.aggregate.assign_object(f, products=[level], relating_object=building)
    api.geometry.edit_object_placement(f, product=level)  # its level: z 0
    elements = []
    for comp in case.components:
        element = entity(classes.get(comp.kind, "IfcBuildingElementProxy"), comp.id)
        w, h = comp.width_m, comp.height_m
        profile = [(0, 0), (w, 0), (w, h), (0, h)]
        if comp.outline is not None:  # a polygon: its outline, from its box's corner
            x0, y0 = comp.x_m - w / 2, comp.y_m - h / 2
            profile = [(x - x0, y - y0) for x, y in comp.outline]
        # an extruded IfcArbitraryClosedProfileDef of the footprint
        rep = api.geometry.add_slab_representation(f, context=body, depth=0.3,
                                                   polyline=profile)
        api.geometry.assign_representation(f, product=element, representation=rep)
        matrix = np.eye(4)
        matrix[:2, 3] = (origin[0] + comp.x_m - w / 2, origin[1] + comp.y_m - h / 2)
        api.geometry.edit_object_placement(f, product=element, matrix=matrix)
        elements.append(element)
    api.spatial.assign_container(f, products=elements, relating_structure=level)
    for k, rel in enumerate(f.by_type("IfcRelationship")):  # made by the API: number them
        rel.GlobalId = ifcopenshell.guid.compress(uuid.uuid5(uuid.NAMESPACE_URL,
                                                             f"{seed}/rel/{k}").hex)
    f.header.file_name.time_stamp = "2026-01-01T00:00:00"
    return f


# -- 4D export -------------------------------------------------------------------------------

def _iso(t: dt.datetime) -> str:
    return t.isoformat(timespec="seconds")


def open_for_4d(model_path: str | Path, case):
    """The model a 4D schedule of ``case`` can be written into, or :class:`CaseError`: a
    case whose components do not name the model's elements, or an IFC2X3 model without the
    user and application that its new entities' mandatory owner history names."""
    model = open_model(model_path)
    source = Path(model_path).name
    if model.schema == "IFC2X3" and not (model.by_type("IfcPersonAndOrganization")
                                         and model.by_type("IfcApplication")):
        raise CaseError(source, ["is IFC2X3, where every entity needs an owner history, but "
                                 "it has no IfcPersonAndOrganization and IfcApplication to "
                                 "name in one; fix: save it again from a BIM tool (which "
                                 "writes them), or as IFC4"])
    missing = [c.id for c in case.components if c.ifc_guid is None]
    unknown = [c.id for c in case.components if c.ifc_guid is not None
               and not _by_guid(model, c.ifc_guid)]
    if len(missing) == len(case.components) or unknown:
        what = (f"components {', '.join(unknown[:5])} name elements that {source} does not have"
                if unknown else "the case's components carry no ifc_guid")
        raise CaseError(source, [f"{what}; fix: export with the model the case was imported "
                                 "from (cmdp-import-ifc)"])
    return model


def export_4d(model_path: str | Path, case, bars, out_path: str | Path,
              start: dt.datetime | None, name: str = "CMDP simulated schedule") -> dict:
    """Write a copy of the model with the simulated schedule as an IfcWorkSchedule.

    Without a working calendar in ``case``, a task's start and finish are ``start`` plus its
    simulated seconds (elapsed time; IfcTaskTime's DurationType ELAPSEDTIME). With one, they
    are the calendar's dates of those seconds (``workcalendar.calendar_datetime``: nights,
    days off and holidays skipped; DurationType WORKTIME, the duration in working seconds),
    and the schedule starts at second 0's date.

    Args:
        model_path: the IFC model the case was imported from (its components' ``ifc_guid``).
        case: the simulated case.
        bars: the simulation's ``schedule.task_bars`` (start and end in simulated seconds).
        out_path: the IFC file to write (atomically).
        start: the date and time of simulated second 0 without a calendar (None with one).
        name: the work schedule's name.

    Returns:
        counts: tasks written, tasks with times, sequences, crews.
    """
    import ifcopenshell.api.control  # noqa: F401
    import ifcopenshell.api.resource
    import ifcopenshell.api.sequence
    import ifcopenshell.guid
    import ifcopenshell.util.date

    from ..events import write_atomic

    model = open_for_4d(model_path, case)
    at, start = _clock(case, start)
    if model.schema == "IFC2X3":
        counts = _write_4d_ifc2x3(model, case, bars, at, start, name)
        write_atomic(Path(out_path), model.to_string())
        return counts
    api = ifcopenshell.api
    schedule = api.sequence.add_work_schedule(model, name=name, predefined_type="PLANNED",
                                              start_time=start)
    crews = {c.id: c for c in case.crews}
    resources = {}
    for crew in case.crews:
        res = api.resource.add_resource(model, ifc_class="IfcCrewResource", name=crew.id)
        res.Description = case.crew_types[crew.type].name
        res.ObjectType = crew.type
        resources[crew.id] = res
    bar_of = {b.task: b for b in bars}
    element_of = {c.id: _by_guid(model, c.ifc_guid) for c in case.components if c.ifc_guid}
    tasks, timed = {}, 0
    for task in case.tasks:
        ifc_task = api.sequence.add_task(model, work_schedule=schedule, name=task.id,
                                         identification=task.id,
                                         description=case.task_types[task.type].name,
                                         predefined_type="CONSTRUCTION")
        tasks[task.id] = ifc_task
        element = element_of.get(task.component)
        if element is not None:
            api.sequence.assign_product(model, relating_product=element, related_object=ifc_task)
        bar = bar_of.get(task.id)
        if bar is None:
            continue
        # Set directly: sequence.edit_task_time snaps starts to 09:00 and finishes to 17:00
        # of a working day, and assign_sequence cascades dates by day; a simulated schedule
        # is in seconds, mapped to dates here (elapsed time, or the case's calendar).
        timed += 1
        duration = dt.timedelta(seconds=bar.end_s - bar.start_s)
        task_time = model.create_entity(
            "IfcTaskTime",
            DurationType="ELAPSEDTIME" if case.calendar is None else "WORKTIME",
            ScheduleStart=_iso(at(bar.start_s)), ScheduleFinish=_iso(at(bar.end_s)),
            ScheduleDuration=ifcopenshell.util.date.datetime2ifc(duration, "IfcDuration"))
        ifc_task.TaskTime = task_time
        ifc_task.Status = "FINISHED" if bar.finished else "NOT FINISHED"
        if bar.crew in crews:
            api.sequence.assign_process(model, relating_process=ifc_task,
                                        related_object=resources[bar.crew])
    sequences = 0
    for task in case.tasks:
        for pred in task.predecessors:
            model.create_entity("IfcRelSequence", GlobalId=ifcopenshell.guid.new(),
                                OwnerHistory=api.owner.create_owner_history(model),
                                RelatingProcess=tasks[pred], RelatedProcess=tasks[task.id],
                                SequenceType="FINISH_START")
            sequences += 1
    write_atomic(Path(out_path), model.to_string())
    return {"tasks": len(tasks), "timed": timed, "sequences": sequences,
            "crews": len(resources)}


def _clock(case, start: dt.datetime | None):
    """(simulated seconds -> date and time, the date of second 0): the case's calendar, or
    elapsed time from ``start``."""
    if case.calendar is not None:
        from ..workcalendar import calendar_datetime, first_working_moment

        calendar = case.calendar
        return (lambda s: calendar_datetime(calendar, s)), first_working_moment(calendar)
    if start is None:
        raise ValueError("export_4d: no start and no working calendar in the case; fix: pass "
                         "start, the date and time of simulated second 0")
    return (lambda s: start + dt.timedelta(seconds=s)), start


def _write_4d_ifc2x3(model, case, bars, at, start: dt.datetime, name: str) -> dict:
    """:func:`export_4d`'s schedule in IFC2X3, written entity by entity: IFC2X3 has no
    IfcTaskTime, and ``ifcopenshell.api.sequence`` writes IFC4's entities.

    Each IfcTask (TaskId and Name: the task's id) is assigned to the IfcWorkSchedule by an
    IfcRelAssignsTasks of its own (the schema's rule: one task each) whose TimeForTask, an
    IfcScheduleTimeControl, holds ScheduleStart and ScheduleFinish (IfcDateAndTime, to the
    second; ``at`` maps simulated seconds to them) and ScheduleDuration (in the model's time
    unit; working time with a calendar). The element it builds is
    assigned as in IFC4 (IfcRelAssignsToProduct), and so is its crew, an IfcCrewResource
    (IfcRelAssignsToProcess: the task is the relating process, the crew what it uses;
    IfcRelAssignsToResource runs the other way, assigning objects to a resource).
    IfcRelSequence needs a TimeLag in IFC2X3: 0. One IfcOwnerHistory, the model's first user
    and application, owns every new entity."""
    import ifcopenshell.api.owner
    import ifcopenshell.api.sequence
    import ifcopenshell.guid
    import ifcopenshell.util.unit

    owner = ifcopenshell.api.owner.create_owner_history(model)
    seconds_per_unit = ifcopenshell.util.unit.calculate_unit_scale(model, "TIMEUNIT")

    def rooted(ifc_class: str, **attributes):
        return model.create_entity(ifc_class, GlobalId=ifcopenshell.guid.new(),
                                   OwnerHistory=owner, **attributes)

    def date_time(t: dt.datetime):  # IFC2X3: an IfcDateAndTime
        return ifcopenshell.api.sequence.add_date_time(model, t)

    user = model.by_type("IfcPersonAndOrganization")[0]
    schedule = rooted("IfcWorkSchedule", Name=name, Identifier=name,
                      CreationDate=date_time(dt.datetime.now()), Creators=[user.ThePerson],
                      StartTime=date_time(start), WorkControlType="PLANNED")
    crews = {c.id: c for c in case.crews}
    resources = {crew.id: rooted("IfcCrewResource", Name=crew.id, ResourceIdentifier=crew.id,
                                 Description=case.crew_types[crew.type].name,
                                 ObjectType=crew.type)
                 for crew in case.crews}
    bar_of = {b.task: b for b in bars}
    element_of = {c.id: _by_guid(model, c.ifc_guid) for c in case.components if c.ifc_guid}
    tasks, timed = {}, 0
    for task in case.tasks:
        ifc_task = rooted("IfcTask", Name=task.id, TaskId=task.id, IsMilestone=False,
                          Description=case.task_types[task.type].name)
        tasks[task.id] = ifc_task
        element = element_of.get(task.component)
        if element is not None:
            rooted("IfcRelAssignsToProduct", RelatedObjects=[ifc_task], RelatingProduct=element)
        bar = bar_of.get(task.id)
        time_control = None
        if bar is not None:
            timed += 1
            time_control = rooted(
                "IfcScheduleTimeControl",
                ScheduleStart=date_time(at(bar.start_s)),
                ScheduleFinish=date_time(at(bar.end_s)),
                ScheduleDuration=(bar.end_s - bar.start_s) / seconds_per_unit)
            ifc_task.Status = "FINISHED" if bar.finished else "NOT FINISHED"
            if bar.crew in crews:
                rooted("IfcRelAssignsToProcess", RelatedObjects=[resources[bar.crew]],
                       RelatingProcess=ifc_task)
        rooted("IfcRelAssignsTasks", RelatedObjects=[ifc_task], RelatingControl=schedule,
               TimeForTask=time_control)
    sequences = 0
    for task in case.tasks:
        for pred in task.predecessors:
            rooted("IfcRelSequence", RelatingProcess=tasks[pred], RelatedProcess=tasks[task.id],
                   TimeLag=0.0, SequenceType="FINISH_START")
            sequences += 1
    return {"tasks": len(tasks), "timed": timed, "sequences": sequences,
            "crews": len(resources)}


def _by_guid(model, guid: str):
    try:
        return model.by_guid(guid)
    except RuntimeError:
        return None


def read_4d(path: str | Path) -> list[dict]:
    """The tasks of an exported 4D model: identification, start, finish (ISO strings), the
    GlobalIds of the elements it builds, its crews, and the identifications of its
    predecessors. For tests and for checking a file."""
    model = open_model(path)
    out = []
    for task in model.by_type("IfcTask"):
        products = [a.RelatingProduct.GlobalId for a in task.HasAssignments or ()
                    if a.is_a("IfcRelAssignsToProduct")]
        crews = [r.Name for rel in task.OperatesOn or () for r in rel.RelatedObjects
                 if r.is_a("IfcCrewResource")]
        preds = [task_code(rel.RelatingProcess) for rel in task.IsSuccessorFrom or ()]
        start, finish = _task_times(task)
        out.append({"id": task_code(task), "start": start, "finish": finish,
                    "products": products, "crews": crews, "predecessors": preds})
    return out


def _task_times(task) -> tuple[str | None, str | None]:
    """A task's scheduled start and finish as ISO strings: IfcTaskTime (IFC4), or the
    IfcScheduleTimeControl of the IfcRelAssignsTasks that assigns it (IFC2X3)."""
    import ifcopenshell.util.date

    if hasattr(task, "TaskTime"):  # IFC4 and later
        time = task.TaskTime
        return (time.ScheduleStart, time.ScheduleFinish) if time else (None, None)

    def iso(value) -> str | None:  # an IfcDateAndTime, IfcCalendarDate or IfcLocalTime
        if value is None:
            return None
        if value.is_a("IfcLocalTime"):
            return f"{value.HourComponent:02d}:{value.MinuteComponent or 0:02d}:" \
                   f"{int(value.SecondComponent or 0):02d}"
        t = ifcopenshell.util.date.ifc2datetime(value)
        return _iso(t) if isinstance(t, dt.datetime) else t.isoformat()

    for rel in task.HasAssignments or ():
        time = rel.TimeForTask if rel.is_a("IfcRelAssignsTasks") else None
        if time is not None:
            return iso(time.ScheduleStart), iso(time.ScheduleFinish)
    return None, None
