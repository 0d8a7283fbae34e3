"""The case data model: a floor's work plane, its crews, components, tasks and storages.

A case is a TOML file a construction engineer can write by hand (see ``docs/case-study.md`` and
the built-in ``cases/precast_floor.toml``). Loading validates it completely before anything is
simulated: every problem is collected and reported in one :class:`CaseError`, each naming the
file, the entry and the fix.

Coordinates: the plane's origin is its centre; x runs along ``width_m``, y along ``height_m``.
So every point of the plane lies in ``[-width/2, width/2] x [-height/2, height/2]`` and Eq. 4's
``x / x_max`` is in [-1, 1].

Units are in the field names (``_m``, ``_s``, ``_min``, ``_m_s``, ``_deg_s``). Work and material
quantities are in the unit named by the crew type's ``work_unit`` and the material's ``unit``.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

BUILTIN_CASE = Path(__file__).with_name("cases") / "precast_floor.toml"

Positive = Annotated[float, Field(gt=0)]
NonNegative = Annotated[float, Field(ge=0)]
UnitIndex = Annotated[float, Field(ge=0, le=1)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class CaseInfo(_Model):
    name: str = "unnamed case"
    description: str = ""


class Plane(_Model):
    """The work plane: a ``width_m`` x ``height_m`` rectangle centred on the origin, walled."""

    width_m: Positive
    height_m: Positive
    outlet_x_m: float
    outlet_y_m: float
    outlet_radius_m: Positive = 1.5

    @property
    def half_extents(self) -> tuple[float, float]:
        """``(x_max, y_max)`` of Eq. 4: half the plane's width and height."""
        return self.width_m / 2.0, self.height_m / 2.0


class Simulation(_Model):
    """Section 5.1's settings and the ray perception model (Fig. 3)."""

    step_s: Positive = 1.0
    physics_substeps: Annotated[int, Field(ge=1, le=20)] = 2
    max_time_s: Positive = 60000.0
    frontal_rays: Annotated[int, Field(ge=1)] = 12
    surrounding_rays: Annotated[int, Field(ge=1)] = 16
    field_of_view_deg: Annotated[float, Field(gt=0, le=360)] = 120.0
    sight_distance_m: Positive = 30.0
    surrounding_distance_m: Positive = 3.0
    turning_rate_deg_s: Positive = 30.0
    lateral_velocity_m_s: Positive = 0.1
    reevaluate_after_steps: Annotated[int, Field(ge=1)] = 300


class ReachingReward(_Model):
    """Eqs. 6-7: eta per object kind (collision or entry penalty), k, and the time penalty."""

    eta_wall: NonNegative = 0.05
    eta_component: NonNegative = 0.05
    eta_storage: NonNegative = 0.05
    eta_crew: NonNegative = 0.2
    eta_task_area: NonNegative = 0.2
    priority_scale_k: Positive = 1.0
    time_penalty: NonNegative = 0.001


class EvaluationReward(_Model):
    """Eq. 5 weights: each term of R_e is one weight times one measured quantity per step."""

    idle_predecessor: float = -0.01  # per crew-step idle for want of a finished predecessor
    idle_area: float = -0.01  # per crew-step idle because task areas block its tasks
    efficiency: float = 0.01  # times the share of crews that are working (not idle)
    episode: float = -0.001  # per step of the episode's duration
    path: float = -0.001  # per crew-step of movement
    completion: float = 1.0  # once, when the last task ends


class TaskType(_Model):
    """One row of Table 2."""

    name: str
    crew_type: str
    area_distance_m: NonNegative
    congestion_index: UnitIndex
    needs_crane: bool = False
    material: str | None = None


class CrewType(_Model):
    """One row of Table 3, plus section 5.1's carry deceleration c and invasion index I_agent.

    A crew type gives either a duration per task (``duration_mean_min``, ``duration_sd_min``)
    or an efficiency in its ``work_unit`` per minute (``efficiency_mean_per_min``,
    ``efficiency_sd_per_min``). Table 3's "variance value" is read as a standard deviation.
    """

    name: str
    work_unit: str = "task"
    duration_mean_min: Positive | None = None
    duration_sd_min: NonNegative | None = None
    efficiency_mean_per_min: Positive | None = None
    efficiency_sd_per_min: NonNegative | None = None
    occupation_area_m2: Positive
    velocity_m_s: Positive
    carry_deceleration: UnitIndex = 1.0
    invasion_index: UnitIndex = 0.0
    carry_capacity: NonNegative = 0.0

    @model_validator(mode="after")
    def _one_pace(self) -> "CrewType":
        by_duration = self.duration_mean_min is not None
        by_efficiency = self.efficiency_mean_per_min is not None
        if by_duration == by_efficiency:
            raise ValueError(
                "give either duration_mean_min (with duration_sd_min) or "
                "efficiency_mean_per_min (with efficiency_sd_per_min), exactly one of them"
            )
        return self

    @property
    def by_duration(self) -> bool:
        return self.duration_mean_min is not None

    @property
    def radius_m(self) -> float:
        """Radius of the disc whose area is the occupation area."""
        return math.sqrt(self.occupation_area_m2 / math.pi)


class Material(_Model):
    """A material of Table 2 with its acquisition efficiency and the crane's lift batch."""

    unit: str
    acquire_per_min: Positive
    crane_lift_quantity: Positive


class Crane(_Model):
    """The tower crane: a shared resource serving requests first come, first served."""

    x_m: float
    y_m: float
    lift_time_s: NonNegative = 240.0  # one lift of material to a storage
    assist_time_s: NonNegative = 180.0  # hoisting assistance for a task that needs the crane


class Crew(_Model):
    id: str
    type: str
    start_x_m: float
    start_y_m: float
    start_heading_deg: float = 0.0


class Component(_Model):
    """A structural component: an axis-aligned rectangle, a static obstacle on the plane."""

    id: str
    kind: str = ""
    x_m: float
    y_m: float
    width_m: Positive
    height_m: Positive


class Storage(_Model):
    """A material storage area: a sensor rectangle whose congestion rises with its stock."""

    id: str
    material: str
    x_m: float
    y_m: float
    width_m: Positive
    height_m: Positive
    capacity: Positive
    congestion_index_full: UnitIndex = 0.5


class Task(_Model):
    """A construction task on a component; ``work`` in its crew's work unit."""

    id: str
    type: str
    component: str
    work: Positive = 1.0
    material_quantity: NonNegative = 0.0
    predecessors: tuple[str, ...] = ()


class Case(_Model):
    """A whole case, validated. Build one with :func:`load_case` or :func:`case_from_dict`."""

    case: CaseInfo = CaseInfo()
    plane: Plane
    simulation: Simulation = Simulation()
    reaching_reward: ReachingReward = ReachingReward()
    evaluation_reward: EvaluationReward = EvaluationReward()
    crane: Crane
    task_types: dict[str, TaskType]
    crew_types: dict[str, CrewType]
    materials: dict[str, Material] = {}
    crews: tuple[Crew, ...]
    components: tuple[Component, ...]
    storages: tuple[Storage, ...] = ()
    tasks: tuple[Task, ...]


@dataclass
class CaseError(ValueError):
    """A case that cannot be simulated; ``problems`` lists every one found."""

    source: str
    problems: list[str]

    def __str__(self) -> str:
        lines = [f"{self.source}: {len(self.problems)} problem(s) in the case:"]
        lines += [f"  {self.source}: {p}" for p in self.problems]
        return "\n".join(lines)


_FIXES = {
    "missing": "add it",
    "extra_forbidden": "remove it or check its spelling",
    "greater_than": "use a positive value",
    "greater_than_equal": "use a value of at least the bound",
    "less_than_equal": "use a value of at most the bound",
    "float_parsing": "write a number",
    "float_type": "write a number",
    "int_type": "write a whole number",
    "int_parsing": "write a whole number",
    "string_type": 'write text in quotes, e.g. "A-01"',
    "bool_type": "write true or false",
    "tuple_type": "write a list, e.g. [1, 2]",
    "dict_type": "write a table",
}


def _entry_label(data: object, loc: tuple) -> str:
    """``tasks[12] "R-07": work`` from a pydantic location, naming entries by their id."""
    parts: list[str] = []
    node = data
    for key in loc:
        if isinstance(key, int):
            parts[-1] = f"{parts[-1]}[{key}]"
            node = node[key] if isinstance(node, (list, tuple)) and key < len(node) else None
            if isinstance(node, dict) and "id" in node:
                parts[-1] += f' "{node["id"]}"'
        else:
            parts.append(str(key))
            node = node.get(key) if isinstance(node, dict) else None
    return ": ".join(parts) if parts else "(top level)"


def _pydantic_problems(data: dict, error: ValidationError) -> list[str]:
    problems = []
    for err in error.errors():
        loc = tuple(k for k in err["loc"] if k not in ("function-after",))
        # Union members add their type name to the location; it tells the user nothing.
        loc = tuple(k for k in loc if not (isinstance(k, str) and k in {"float", "none"}))
        fix = _FIXES.get(err["type"], "see docs/case-study.md for the field's meaning")
        msg = err["msg"].removeprefix("Value error, ")
        problems.append(f"{_entry_label(data, loc)}: {msg}; fix: {fix}")
    return sorted(set(problems), key=problems.index)


def _did_you_mean(name: str, known) -> str:
    close = difflib.get_close_matches(name, list(known), n=1)
    return f'; did you mean "{close[0]}"?' if close else f"; known: {', '.join(sorted(known))}"


def _rect(item) -> tuple[float, float, float, float]:
    return (
        item.x_m - item.width_m / 2,
        item.y_m - item.height_m / 2,
        item.x_m + item.width_m / 2,
        item.y_m + item.height_m / 2,
    )


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _semantic_problems(case: Case) -> list[str]:
    """Cross-references and geometry that field-by-field validation cannot see."""
    problems: list[str] = []
    half_w, half_h = case.plane.half_extents

    def outside(x0, y0, x1, y1) -> bool:
        return x0 < -half_w or x1 > half_w or y0 < -half_h or y1 > half_h

    for name, tt in case.task_types.items():
        if tt.crew_type not in case.crew_types:
            problems.append(
                f'task_types: {name}: crew_type names unknown crew type "{tt.crew_type}"'
                f"{_did_you_mean(tt.crew_type, case.crew_types)}"
            )
        if tt.material is not None and tt.material not in case.materials:
            problems.append(
                f'task_types: {name}: material "{tt.material}" is not in [materials]'
                f"{_did_you_mean(tt.material, case.materials)}"
            )
        elif tt.material is not None and not any(s.material == tt.material for s in case.storages):
            problems.append(
                f'task_types: {name}: material "{tt.material}" has no storage that supplies it; '
                "fix: add a [[storages]] entry with this material"
            )
        if tt.material is not None and tt.crew_type in case.crew_types:
            if case.crew_types[tt.crew_type].carry_capacity <= 0:
                problems.append(
                    f"crew_types: {tt.crew_type}: carry_capacity must be positive because its "
                    f'task type {name} needs material "{tt.material}"; fix: set carry_capacity'
                )
    crews_of_type = {c.type for c in case.crews}
    for i, crew in enumerate(case.crews):
        if crew.type not in case.crew_types:
            problems.append(
                f'crews[{i}] "{crew.id}": type names unknown crew type "{crew.type}"'
                f"{_did_you_mean(crew.type, case.crew_types)}"
            )
        elif not (abs(crew.start_x_m) < half_w and abs(crew.start_y_m) < half_h):
            problems.append(
                f'crews[{i}] "{crew.id}": start ({crew.start_x_m}, {crew.start_y_m}) is outside '
                f"the plane [-{half_w}, {half_w}] x [-{half_h}, {half_h}]; fix: move it inside"
            )
    for label, items in (("crews", case.crews), ("components", case.components),
                         ("storages", case.storages), ("tasks", case.tasks)):
        seen: set[str] = set()
        for i, item in enumerate(items):
            if item.id in seen:
                problems.append(f'{label}[{i}] "{item.id}": id used twice; fix: rename one')
            seen.add(item.id)
    rects = []
    for i, comp in enumerate(case.components):
        r = _rect(comp)
        if outside(*r):
            problems.append(
                f'components[{i}] "{comp.id}": rectangle {tuple(round(v, 3) for v in r)} lies '
                f"outside the plane [-{half_w}, {half_w}] x [-{half_h}, {half_h}]; "
                "fix: move or shrink it"
            )
        for j, (other, ro) in enumerate(rects):
            if _overlap(r, ro):
                problems.append(
                    f'components[{i}] "{comp.id}": overlaps components[{j}] "{other.id}"; '
                    "fix: move one of them"
                )
        rects.append((comp, r))
    for i, st in enumerate(case.storages):
        if st.material not in case.materials:
            problems.append(
                f'storages[{i}] "{st.id}": material "{st.material}" is not in [materials]'
                f"{_did_you_mean(st.material, case.materials)}"
            )
        if outside(*_rect(st)):
            problems.append(f'storages[{i}] "{st.id}": lies outside the plane; fix: move it inside')
    if not (abs(case.plane.outlet_x_m) <= half_w and abs(case.plane.outlet_y_m) <= half_h):
        problems.append("plane: the outlet lies outside the plane; fix: move it onto the plane")

    component_ids = {c.id for c in case.components}
    task_ids = {t.id for t in case.tasks}
    for i, task in enumerate(case.tasks):
        where = f'tasks[{i}] "{task.id}"'
        if task.type not in case.task_types:
            problems.append(
                f'{where}: type names unknown task type "{task.type}"'
                f"{_did_you_mean(task.type, case.task_types)}"
            )
        elif case.task_types[task.type].crew_type not in crews_of_type:
            problems.append(
                f'{where}: no crew performs task type "{task.type}" (it needs a '
                f'"{case.task_types[task.type].crew_type}" crew); fix: add one to [[crews]]'
            )
        if task.component not in component_ids:
            problems.append(
                f'{where}: names component "{task.component}" which does not exist'
                f"{_did_you_mean(task.component, component_ids)}"
            )
        for pred in task.predecessors:
            if pred not in task_ids:
                problems.append(
                    f'{where}: precedence names unknown task "{pred}"'
                    f"{_did_you_mean(pred, task_ids)}"
                )
            elif pred == task.id:
                problems.append(f"{where}: precedes itself; fix: remove it from predecessors")
    cycle = _find_cycle(case.tasks)
    if cycle:
        problems.append(
            "tasks: precedence cycle " + " -> ".join(cycle) + "; fix: remove one of these links"
        )
    return problems


def _find_cycle(tasks) -> list[str] | None:
    """A precedence cycle as a list of task ids (first repeated last), or None."""
    preds = {t.id: [p for p in t.predecessors if p != t.id] for t in tasks}
    colour: dict[str, int] = {}
    for start in preds:
        if colour.get(start):
            continue
        stack = [(start, iter(preds[start]))]
        path = [start]
        colour[start] = 1
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                colour[node] = 2
                stack.pop()
                path.pop()
            elif nxt in preds:
                if colour.get(nxt) == 1:
                    return path[path.index(nxt):] + [nxt]
                if not colour.get(nxt):
                    colour[nxt] = 1
                    stack.append((nxt, iter(preds[nxt])))
                    path.append(nxt)
    return None


def case_from_dict(data: dict, source: str = "<case>") -> Case:
    """Validate raw case data; raise :class:`CaseError` listing every problem."""
    if not isinstance(data, dict):
        raise CaseError(source, ["the case must be a table of sections"])
    try:
        case = Case.model_validate(data)
    except ValidationError as err:
        raise CaseError(source, _pydantic_problems(data, err)) from None
    problems = _semantic_problems(case)
    if problems:
        raise CaseError(source, problems)
    return case


def load_case(path: str | Path | None = None) -> Case:
    """Load and validate a case file (TOML); ``None`` loads the built-in case."""
    path = Path(path) if path is not None else BUILTIN_CASE
    source = path.name
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as err:
        raise CaseError(str(path), [f"cannot read the file ({err.strerror}); fix: check the path"])
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise CaseError(source, [f"malformed TOML: {err}; fix: correct the syntax there"]) from None
    return case_from_dict(data, source)


def as_case(case: Case | str | Path | dict | None) -> Case:
    """Accept a Case, a path, raw data or None (the built-in case)."""
    if isinstance(case, Case):
        return case
    if isinstance(case, dict):
        return case_from_dict(case)
    return load_case(case)


__all__ = ["Case", "CaseError", "load_case", "case_from_dict", "as_case", "BUILTIN_CASE"]
