"""The case data model: a floor's work plane, its crews, components, tasks and storages.

Pydantic models, frozen and strict; loading a case file and checking it as a whole (every
problem reported together, naming the file, the entry and the fix) is ``cases.load``'s job.

Coordinates: the plane's origin is its centre; x runs along ``width_m``, y along ``height_m``.
So every point of the plane lies in ``[-width/2, width/2] x [-height/2, height/2]`` and Eq. 4's
``x / x_max`` is in [-1, 1].

Units are in the field names (``_m``, ``_s``, ``_min``, ``_m_s``, ``_deg_s``). Work and material
quantities are in the unit named by the crew type's ``work_unit`` and the material's ``unit``.
"""

from __future__ import annotations

import datetime as dt
import difflib
import functools
import math
import re
from typing import Annotated

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    Strict,
    field_validator,
    model_serializer,
    model_validator,
)

from ..geometry import Outline, outline, outline_problems

# Scalars are strict: a quoted "0.4" in a case file is a mistake to report, not to guess at.
# (Strict floats still accept whole numbers, so ``width_m = 54`` is fine.) TOML has ``nan`` and
# ``inf``: no quantity of a floor is either, and a NaN coordinate stalls a run.
Number = Annotated[float, Strict(), Field(allow_inf_nan=False)]
Positive = Annotated[float, Strict(), Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Strict(), Field(ge=0, allow_inf_nan=False)]
UnitIndex = Annotated[float, Strict(), Field(ge=0, le=1, allow_inf_nan=False)]
Flag = Annotated[bool, Strict()]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class CaseInfo(_Model):
    name: str = "unnamed case"
    description: str = ""


class Plane(_Model):
    """The work plane: a ``width_m`` x ``height_m`` rectangle centred on the origin, walled."""

    width_m: Positive
    height_m: Positive
    outlet_x_m: Number
    outlet_y_m: Number
    outlet_radius_m: Positive = 1.5

    @property
    def half_extents(self) -> tuple[float, float]:
        """``(x_max, y_max)`` of Eq. 4: half the plane's width and height."""
        return self.width_m / 2.0, self.height_m / 2.0


class Simulation(_Model):
    """Section 5.1's settings and the ray perception model (Fig. 3)."""

    step_s: Positive = 1.0
    physics_substeps: Annotated[int, Strict(), Field(ge=1, le=20)] = 2
    max_time_s: Positive = 60000.0
    frontal_rays: Annotated[int, Strict(), Field(ge=1)] = 12
    surrounding_rays: Annotated[int, Strict(), Field(ge=1)] = 16
    field_of_view_deg: Annotated[float, Strict(), Field(gt=0, le=360, allow_inf_nan=False)] \
        = 120.0
    sight_distance_m: Positive = 30.0
    surrounding_distance_m: Positive = 3.0
    turning_rate_deg_s: Positive = 30.0
    lateral_velocity_m_s: Positive = 0.1
    reevaluate_after_steps: Annotated[int, Strict(), Field(ge=1)] = 300
    # Beyond the paper (its section 6 names a "memory storage" as the remedy for blind spots):
    # the reaching observation also carries where the crew last saw a target of its scope.
    target_memory: Annotated[bool, Strict()] = False


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

    idle_predecessor: Number = -0.01  # per crew-step idle for want of a finished predecessor
    idle_area: Number = -0.01  # per crew-step idle because task areas block its tasks
    efficiency: Number = 0.01  # times the share of crews that are working (not idle)
    episode: Number = -0.001  # per step of the episode's duration
    path: Number = -0.001  # per crew-step of movement
    completion: Number = 1.0  # once, when the last task ends


class TaskType(_Model):
    """One row of Table 2."""

    name: str
    crew_type: str
    area_distance_m: NonNegative
    congestion_index: UnitIndex
    needs_crane: Flag = False
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
    def _one_pace(self) -> CrewType:
        by_duration = self.duration_mean_min is not None
        by_efficiency = self.efficiency_mean_per_min is not None
        if by_duration == by_efficiency:
            raise ValueError(
                "a crew type needs exactly one pace, a duration or an efficiency; fix: give "
                "either duration_mean_min (with duration_sd_min) or efficiency_mean_per_min "
                "(with efficiency_sd_per_min), not both or neither"
            )
        stray = "efficiency_sd_per_min" if by_duration else "duration_sd_min"
        if getattr(self, stray) is not None:
            mean = "duration_mean_min" if by_duration else "efficiency_mean_per_min"
            raise ValueError(
                f"{stray} does not go with {mean}; fix: give the spread in the same kind as "
                f"the mean ({mean.replace('mean', 'sd')})"
            )
        return self

    @property
    def by_duration(self) -> bool:
        return self.duration_mean_min is not None

    def mean_seconds(self, work: float) -> float:
        """Expected working time for ``work`` units at Table 3's mean: a duration crew's
        duration is per unit of work (a task of work 1 takes one duration)."""
        if self.by_duration:
            return self.duration_mean_min * 60.0 * work
        return work / self.efficiency_mean_per_min * 60.0

    @property
    def radius_m(self) -> float:
        """Radius of the disc whose area is the occupation area."""
        return math.sqrt(self.occupation_area_m2 / math.pi)


class Material(_Model):
    """A material of Table 2 with its acquisition efficiency and the crane's lift batch.

    ``reorder_at``: the stock (in ``unit``) at or below which a crew that fetches from a
    storage asks the crane for the next lift while it goes on loading (a reorder point). The
    default 0 is Table 1's c7 as the paper's case reads it: a lift is asked for only when a
    crew finds the storage empty, and the crew waits for it (docs/case-study.md).
    """

    unit: str
    acquire_per_min: Positive
    crane_lift_quantity: Positive
    reorder_at: NonNegative = 0.0


class Crane(_Model):
    """The tower crane: a shared resource serving requests first come, first served."""

    x_m: Number
    y_m: Number
    lift_time_s: NonNegative = 240.0  # one lift of material to a storage
    assist_time_s: NonNegative = 180.0  # hoisting assistance for a task that needs the crane


class Crew(_Model):
    id: str
    type: str
    start_x_m: Number
    start_y_m: Number
    start_heading_deg: Number = 0.0


class Component(_Model):
    """A structural component: an axis-aligned rectangle, or a polygon (``outline``), a
    static obstacle on the plane.

    ``outline``: the component's footprint as a simple polygon, ``[[x, y], ...]`` in plane
    coordinates (m), either winding (stored counter-clockwise), at least 3 corners, no edges
    crossing (``cmdp_pymunk.geometry``). With it, ``x_m``, ``y_m``, ``width_m`` and
    ``height_m`` may be left out: they are its bounding box (given, they must be that box),
    which is all that needs a box reads; its task areas are the polygon grown by the area
    distance. Without it the component is its rectangle, as before polygons.

    ``ifc_guid``: the GlobalId of the IFC element it was imported from (``cmdp-import-ifc``);
    the 4D export (``cmdp-simulate --ifc``) assigns the component's tasks to that element.

    ``deck``: walked on once laid (a slab of a wide-slab or hollow-core deck). Until it is laid
    it is an obstacle like any component (the void between its bearings); once its laying task
    has ended (``cases.reach.laying_tasks``: its first task whose type needs the crane, the
    hoisting and installation, else its last task) crews walk over it.
    """

    id: str
    kind: str = ""
    x_m: Number
    y_m: Number
    width_m: Positive
    height_m: Positive
    ifc_guid: str | None = None
    deck: Flag = False
    outline: tuple[tuple[Number, Number], ...] | None = None

    @model_validator(mode="before")
    @classmethod
    def _box_of_outline(cls, data: object) -> object:
        # An outline's component may leave its rectangle out: it is the outline's box.
        if not isinstance(data, dict) or data.get("outline") is None:
            return data
        points = data["outline"]
        try:
            xs = [float(p[0]) for p in points]
            ys = [float(p[1]) for p in points]
        except (TypeError, ValueError, IndexError):
            return data  # the field's own validation names what is wrong
        if not xs:
            return data
        box = {"x_m": (min(xs) + max(xs)) / 2, "y_m": (min(ys) + max(ys)) / 2,
               "width_m": max(xs) - min(xs), "height_m": max(ys) - min(ys)}
        given = {k: data[k] for k in box if k in data}
        off = [k for k, v in given.items() if isinstance(v, (int, float))
               and not math.isclose(v, box[k], rel_tol=1e-9, abs_tol=1e-6)]
        if off:
            raise ValueError(
                f"{', '.join(off)} disagree with the outline's bounding box (x_m = "
                f"{box['x_m']:g}, y_m = {box['y_m']:g}, width_m = {box['width_m']:g}, "
                f"height_m = {box['height_m']:g}); fix: leave x_m, y_m, width_m and "
                "height_m out (an outline's component is its box) or give that box")
        return {**box, **data}

    @field_validator("outline")
    @classmethod
    def _simple_polygon(cls, value):
        if value is None:
            return value
        problems = outline_problems(value)
        if problems:
            raise ValueError("; ".join(problems))
        return outline(value).points

    @property
    def shape(self):
        """Its footprint on the plane: the rectangle ``(x0, y0, x1, y1)``, or the
        ``geometry.Outline`` of its outline (a tuple too: its bounding box)."""
        if self.outline is not None:
            return Outline(self.outline)
        return (self.x_m - self.width_m / 2, self.y_m - self.height_m / 2,
                self.x_m + self.width_m / 2, self.y_m + self.height_m / 2)

    @model_serializer(mode="wrap")
    def _without_deck_false(self, handler):
        # A component that is no deck, or a rectangle, dumps as before decks and outlines
        # existed (case.json, run records, the event floor's calibration fingerprint).
        data = handler(self)
        if isinstance(data, dict):
            if not data.get("deck", True):
                data.pop("deck")
            if data.get("outline", 0) is None:
                data.pop("outline")
        return data


class Storage(_Model):
    """A material storage area: a sensor rectangle whose congestion rises with its stock."""

    id: str
    material: str
    x_m: Number
    y_m: Number
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


class Disruption(_Model):
    """One disruption entry: when it strikes and how long it lasts (docs/disruptions.md).

    When: a scheduled one gives ``at_s`` (the simulated second it starts; ``every_s`` repeats
    it, e.g. 86400 for a daily window); a random one gives ``mean_interval_s``, the mean time
    between the end of one occurrence and the start of the next (exponential gaps: a failure
    rate, "mean time between failures"), from the episode's start. How long: ``duration_s``,
    or ``duration_mean_s`` with ``duration_sd_s`` (a gamma distribution with that mean and
    standard deviation; sd 0 or absent: always the mean). A random entry draws from its own
    stream (``streams``), so it changes no task's pace.
    """

    at_s: NonNegative | None = None
    every_s: Positive | None = None
    mean_interval_s: Positive | None = None
    duration_s: Positive | None = None
    duration_mean_s: Positive | None = None
    duration_sd_s: NonNegative | None = None

    @model_validator(mode="after")
    def _one_when_one_duration(self) -> Disruption:
        if (self.at_s is None) == (self.mean_interval_s is None):
            raise ValueError(
                "a disruption needs exactly one of at_s (scheduled) and mean_interval_s "
                "(random); fix: give at_s = <second it starts> or mean_interval_s = <mean "
                "seconds between occurrences>, not both or neither")
        if (self.duration_s is None) == (self.duration_mean_s is None):
            raise ValueError(
                "a disruption needs exactly one of duration_s and duration_mean_s; fix: give "
                "duration_s = <seconds> or duration_mean_s (with duration_sd_s), not both or "
                "neither")
        if self.duration_sd_s is not None and self.duration_mean_s is None:
            raise ValueError("duration_sd_s goes with duration_mean_s; fix: replace duration_s "
                             "by duration_mean_s, or remove duration_sd_s")
        if self.every_s is not None and self.at_s is None:
            raise ValueError("every_s repeats a scheduled disruption; fix: give at_s too, or "
                             "remove every_s (a random one recurs by itself)")
        if self.every_s is not None and self.duration_s is not None \
                and self.every_s <= self.duration_s:
            raise ValueError(f"every_s = {self.every_s:g} s is not longer than duration_s = "
                             f"{self.duration_s:g} s, so each occurrence would overlap the "
                             "next; fix: make every_s longer than duration_s")
        if self.every_s is not None and self.duration_mean_s is not None:
            raise ValueError("a repeated (every_s) disruption needs a fixed duration_s; fix: "
                             "replace duration_mean_s by duration_s")
        return self

    @property
    def scheduled(self) -> bool:
        return self.at_s is not None

    @property
    def longest_s(self) -> float:
        """Its fixed duration or its mean duration (what the time-limit check reads)."""
        return self.duration_s if self.duration_s is not None else self.duration_mean_s


class CraneBreakdown(Disruption):
    """The crane breaks down: it serves no request until it is repaired (the duration)."""


class LateDelivery(Disruption):
    """A storage's material delivery is late: no crane lift restocks it for the duration."""

    storage: str


class Absence(Disruption):
    """A crew is absent: it leaves the plane and comes back after the duration."""

    crew: str


class WeatherStop(Disruption):
    """A weather stop: all outdoor work halts (tasks, fetching, the crane) for the duration."""


class Disruptions(_Model):
    """What goes wrong beyond task paces (beyond the paper; docs/disruptions.md). Absent or
    empty: the floor runs exactly as without this section."""

    crane_breakdowns: tuple[CraneBreakdown, ...] = ()
    late_deliveries: tuple[LateDelivery, ...] = ()
    absences: tuple[Absence, ...] = ()
    weather_stops: tuple[WeatherStop, ...] = ()

    def __bool__(self) -> bool:
        return bool(self.crane_breakdowns or self.late_deliveries or self.absences
                    or self.weather_stops)


WEEKDAYS = ("Mon", "Tue", "Wed", "Thu", "Fri", "Sat", "Sun")  # date.weekday() order
_FULL_DAYS = ("monday", "tuesday", "wednesday", "thursday", "friday", "saturday", "sunday")
_HOURS = re.compile(r"^\s*(\d{1,2}):(\d{2})\s*-\s*(\d{1,2}):(\d{2})\s*$")


def _weekday(name: object) -> int:
    """Index (Mon 0) of a weekday written "Mon", "mon" or "Monday"; ValueError naming the fix."""
    text = str(name).strip().casefold()
    for i, full in enumerate(_FULL_DAYS):
        if text in (full, full[:3]):
            return i
    close = difflib.get_close_matches(text, [*_FULL_DAYS, *(d[:3] for d in _FULL_DAYS)], 1)
    hint = f'did you mean "{close[0][:3].title()}"? ' if close else ""
    raise ValueError(f"{_quoted(name)} is not a weekday; fix: {hint}(weekdays: Mon, Tue, Wed, "
                     'Thu, Fri, Sat, Sun; a range such as "Mon-Fri"; a list such as '
                     '["Mon", "Wed"])')


def _quoted(value: object) -> str:
    """A value as a message shows it: text in double quotes, anything else as Python's."""
    return f'"{value}"' if isinstance(value, str) else repr(value)


def parse_working_days(value: object) -> tuple[str, ...]:
    """``"Mon-Fri"``, ``"Mon-Wed, Fri"``, ``["Mon", "Tue"]`` -> the days in week order, e.g.
    ``("Mon", "Tue", "Wed", "Thu", "Fri")``. A range runs forward through the week and may
    wrap (``"Sun-Thu"``: Sun, Mon, Tue, Wed, Thu)."""
    if isinstance(value, str):
        items: list[object] = [part for part in value.split(",") if part.strip()]
    elif isinstance(value, (list, tuple)):
        items = list(value)
    else:
        raise ValueError('working days are text or a list; fix: write e.g. "Mon-Fri" or '
                         '["Mon", "Tue", "Wed", "Thu", "Fri"]')
    days: set[int] = set()
    for item in items:
        if isinstance(item, str) and "-" in item:
            first, last = (_weekday(part) for part in item.split("-", 1))
            days.update((first + k) % 7 for k in range((last - first) % 7 + 1))
        else:
            days.add(_weekday(item))
    if not days:
        raise ValueError('no working day; fix: give at least one, e.g. "Mon-Fri"')
    return tuple(WEEKDAYS[i] for i in sorted(days))


def parse_working_hours(value: object) -> tuple[int, int]:
    """``"08:00-16:00"`` -> (28800, 57600): the working day's opening and closing, in seconds
    after midnight. The close may be ``24:00`` (midnight); it must come after the opening (a
    shift across midnight is not supported)."""
    if isinstance(value, str):
        return _parsed_hours(value)
    return _parse_working_hours(value)  # not a string: its error


@functools.lru_cache(maxsize=64)  # read at every date a schedule converts (a few per task)
def _parsed_hours(value: str) -> tuple[int, int]:
    return _parse_working_hours(value)


def _parse_working_hours(value: object) -> tuple[int, int]:
    match = _HOURS.match(value) if isinstance(value, str) else None
    if match is None:
        raise ValueError(f"{_quoted(value)} is not a time range; fix: write opening and closing as "
                         'HH:MM-HH:MM, e.g. "08:00-16:00"')
    h0, m0, h1, m1 = (int(g) for g in match.groups())
    for h, m in ((h0, m0), (h1, m1)):
        if m > 59 or h > 24 or (h == 24 and m > 0):
            raise ValueError(f'"{value}": {h:02d}:{m:02d} is not a time of day; fix: use '
                             "00:00 to 24:00")
    opening, closing = (h0 * 60 + m0) * 60, (h1 * 60 + m1) * 60
    if closing <= opening:
        raise ValueError(f'"{value}" ends before it starts (or as it starts); fix: give the '
                         'opening first, e.g. "08:00-16:00" (a shift across midnight is not '
                         "supported)")
    return opening, closing


def _as_date(value: object) -> dt.date:
    if isinstance(value, dt.datetime):
        raise ValueError(f"{value.isoformat()} has a time of day; fix: a holiday is a whole "
                         "date, write YYYY-MM-DD")
    if isinstance(value, dt.date):
        return value
    if isinstance(value, str):
        try:
            return dt.date.fromisoformat(value.strip())
        except ValueError:
            pass
    raise ValueError(f"{_quoted(value)} is not a date; fix: write YYYY-MM-DD, e.g. 2026-12-25")


class Calendar(_Model):
    """A working calendar, so that simulated seconds become dates (beyond the paper).

    Simulated time counts working time only: the crews work from the opening to the closing of
    ``working_hours`` on the ``working_days`` that are not ``holidays``, and the clock stands
    still in between. Second 0 is ``start``, or, when ``start`` is not working time, the next
    working moment (``cmdp_pymunk.workcalendar``, which maps seconds to dates).

    ``start``: a local date and time (TOML ``2026-01-05T08:00:00`` or text; a date alone is
    its midnight); ``working_hours``: ``"HH:MM-HH:MM"``; ``working_days``: ``"Mon-Fri"`` or a
    list of weekdays, stored as the days in week order; ``holidays``: dates (``YYYY-MM-DD``).
    """

    start: dt.datetime
    working_hours: str = "08:00-16:00"
    working_days: tuple[str, ...] = WEEKDAYS[:5]
    holidays: tuple[dt.date, ...] = ()

    @field_validator("start", mode="before")
    @classmethod
    def _start(cls, value: object) -> dt.datetime:
        if isinstance(value, str):
            try:
                value = dt.datetime.fromisoformat(value.strip())
            except ValueError:
                raise ValueError(f"{_quoted(value)} is not a date and time; fix: write "
                                 "YYYY-MM-DDTHH:MM, e.g. 2026-01-05T08:00") from None
        if isinstance(value, dt.date) and not isinstance(value, dt.datetime):
            value = dt.datetime.combine(value, dt.time())
        if not isinstance(value, dt.datetime):
            raise ValueError(f"{_quoted(value)} is not a date and time; fix: write "
                             "YYYY-MM-DDTHH:MM, "
                             "e.g. 2026-01-05T08:00")
        if value.tzinfo is not None:
            raise ValueError(f"{value.isoformat()} has a UTC offset; fix: give the site's "
                             "local time without an offset, e.g. 2026-01-05T08:00")
        return value

    @field_validator("working_hours", mode="before")
    @classmethod
    def _hours(cls, value: object) -> str:
        opening, closing = parse_working_hours(value)
        return f"{opening // 3600:02d}:{opening % 3600 // 60:02d}-" \
               f"{closing // 3600:02d}:{closing % 3600 // 60:02d}"

    @field_validator("working_days", mode="before")
    @classmethod
    def _days(cls, value: object) -> tuple[str, ...]:
        return parse_working_days(value)

    @field_validator("holidays", mode="before")
    @classmethod
    def _holidays(cls, value: object) -> tuple[dt.date, ...]:
        if isinstance(value, str):
            value = [part for part in value.split(",") if part.strip()]
        if not isinstance(value, (list, tuple)):
            raise ValueError("holidays are a list of dates; fix: write e.g. "
                             "[2026-01-12, 2026-12-25]")
        return tuple(sorted(set(_as_date(v) for v in value)))

    @property
    def opening_s(self) -> int:
        """Seconds after midnight at which a working day opens."""
        return parse_working_hours(self.working_hours)[0]

    @property
    def closing_s(self) -> int:
        """Seconds after midnight at which a working day closes."""
        return parse_working_hours(self.working_hours)[1]


# -- beyond the paper: what a run costs, and what a planner may change (docs/levers.md) -------

Count = Annotated[int, Strict(), Field(ge=0)]
Bounds = tuple[NonNegative, NonNegative]


class Cost(_Model):
    """``[cost]``: what a floor costs per hour, beside its makespan (``cmdp_pymunk.cost``).

    Every crew is paid from the floor's start to its makespan (``crew_rate_per_h`` per crew
    of a type; a type not named there costs ``default_crew_rate_per_h``); the crane is hired
    per hour and optionally per lift (``crane_per_lift``: each crane lift or hoisting
    assistance); the site's time-related overhead runs per hour; past ``due_s`` (simulated,
    i.e. working, seconds) ``penalty_per_day`` is charged per working day of ``day_s``
    seconds, pro rata. The defaults are assumptions, not sourced rates (docs/levers.md).
    """

    currency: str = "EUR"
    crew_rate_per_h: dict[str, NonNegative] = {}
    default_crew_rate_per_h: NonNegative = 200.0
    crane_per_h: NonNegative = 150.0
    crane_per_lift: NonNegative = 0.0
    overhead_per_h: NonNegative = 250.0
    due_s: Positive | None = None
    penalty_per_day: NonNegative = 0.0
    day_s: Positive = 28800.0

    @model_validator(mode="after")
    def _penalty_needs_due(self) -> Cost:
        if self.penalty_per_day > 0 and self.due_s is None:
            raise ValueError("penalty_per_day is charged past a due date, and there is none; "
                             "fix: add due_s = <simulated seconds> or remove penalty_per_day")
        return self

    def crew_rate(self, crew_type: str) -> float:
        """A crew of ``crew_type``'s rate per hour."""
        return self.crew_rate_per_h.get(crew_type, self.default_crew_rate_per_h)


class CrewLever(_Model):
    """How many crews of one type a variant may have (``min`` to ``max``), and optionally the
    start points added crews take, in order (``starts``, [x, y] in metres); without them an
    added crew starts at the free point nearest its type's starts (``levers.free_starts``)."""

    min: Count = 0
    max: Count
    starts: tuple[tuple[Number, Number], ...] = ()

    @model_validator(mode="after")
    def _ordered(self) -> CrewLever:
        if self.min > self.max:
            raise ValueError(f"min = {self.min} is above max = {self.max}; fix: give the "
                             "fewest crews as min and the most as max")
        return self


def _ordered_bounds(bounds: tuple[float, float] | None, name: str) -> None:
    if bounds is not None and bounds[0] > bounds[1]:
        raise ValueError(f"{name} = [{bounds[0]:g}, {bounds[1]:g}] runs backwards; fix: give "
                         "[lowest, highest]")


class MaterialLever(_Model):
    """Within which bounds a material's reorder point (``reorder_at``) and crane lift batch
    (``crane_lift_quantity``) may move, each ``[lowest, highest]`` in the material's unit."""

    reorder_at: Bounds | None = None
    crane_lift_quantity: tuple[Positive, Positive] | None = None

    @model_validator(mode="after")
    def _ordered(self) -> MaterialLever:
        _ordered_bounds(self.reorder_at, "reorder_at")
        _ordered_bounds(self.crane_lift_quantity, "crane_lift_quantity")
        return self


class StorageLever(_Model):
    """Where a storage may move (``spots``: candidate centres [x, y]; or ``region``: [x0, y0,
    x1, y1], the rectangle its centre may lie in) and within which bounds its capacity may
    change (``capacity``: [lowest, highest])."""

    spots: tuple[tuple[Number, Number], ...] = ()
    region: tuple[Number, Number, Number, Number] | None = None
    capacity: tuple[Positive, Positive] | None = None

    @model_validator(mode="after")
    def _ordered(self) -> StorageLever:
        _ordered_bounds(self.capacity, "capacity")
        if self.region is not None and (self.region[0] > self.region[2]
                                        or self.region[1] > self.region[3]):
            raise ValueError("region runs backwards; fix: give [x0, y0, x1, y1] with x0 <= x1 "
                             "and y0 <= y1")
        return self


class Levers(_Model):
    """``[levers]``: what a variant of the case may change, and within which bounds
    (``cmdp_pymunk.cases.levers``). A case without it may change any of these levers; a case
    with it only those it names."""

    crews: dict[str, CrewLever] = {}
    materials: dict[str, MaterialLever] = {}
    storages: dict[str, StorageLever] = {}


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
    crews: Annotated[tuple[Crew, ...], Field(min_length=1)]
    components: tuple[Component, ...]
    storages: tuple[Storage, ...] = ()
    tasks: Annotated[tuple[Task, ...], Field(min_length=1)]
    disruptions: Disruptions = Disruptions()
    calendar: Calendar | None = None
    cost: Cost | None = None
    levers: Levers | None = None

    @model_serializer(mode="wrap")
    def _without_absent_sections(self, handler):
        # A case without a calendar, a cost model or levers dumps as before they existed
        # (case.json, run records, the event floor's calibration fingerprint).
        data = handler(self)
        if isinstance(data, dict):
            for section in ("calendar", "cost", "levers"):
                if data.get(section) is None:
                    data.pop(section, None)
        return data
