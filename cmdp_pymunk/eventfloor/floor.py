"""The event floor: the CMDP's construction process jumping from event to event.

The same engine (``engine.Engine``), case, construction state (``state.Site``), decision
table (Table 1, ``decide``), P_cons (``construct``, Eq. 2), crane queue, precedence, random
streams (a task's pace is the one it draws on the pymunk floor on the same seed), disruptions
(``disruptions``), event log and evaluators as the pymunk floor, moved by another motion
(``WalkMotion``, a ``motion.Motion``) instead of per-second physics and a low level: a crew
that holds target values walks to the best of them (``policy.best_target``'s rule: highest
V_Tar, lowest index on ties) along the shortest path, in the time Eq. 1 gives along it
(``walks``), and arrives at a whole second.

Between two events every rate is constant (task paces under the calibrated invasion of
Eq. 2, loading rates, the crane's countdown, the walks), so a span runs to the next
second at which anything can change, and the engine runs there exactly what it runs at the
end of a second on the pymunk floor: P_cons for the seconds jumped (``construct.advance`` with
``dt`` of many seconds), disruptions, the decision table, the target evaluation, the event
log, the counting. Events (P_cons' own from ``construct.next_change_in``, beside its rules):

- a task ends, or its crew's load runs out (c9, c3); a load is full, or the storage empty (c6,
  c7), or down to its material's reorder point (``construct.reorder``) or, with a logistics
  role, to its next decision level (``logistics``); the crane's lift or assistance is done;
- a walk arrives (c1, c4, c5, c7, the outlet);
- a disruption starts or ends (``disruptions.Timeline``), and a walker's re-evaluation is due
  (``reevaluate_after_steps`` seconds without a reach, section 3.6);
- a row of the table would fire in the next second (``decide.only_execution_fires`` false):
  what the pymunk engine would do a second later happens a second later here too (a crew
  whose scope went stale re-acquires).

The loop is a plain one over "the next event" rather than SimPy's processes: every event time
follows from the state at the last event (nothing here waits on a resource but the crane,
whose queue is the site's), and a floor must branch (``clone``): a heap of generators cannot
be copied, a site can (``Engine.clone``, with ``motion=WalkMotion(...)`` from the pymunk
floor). Crews walking when the site changes re-value (c10 and the evaluator,
with where they are along the path now) and turn to a new best target from there.

What it is not: crews are points on their paths, so contacts, swerving and jams are in the
calibrated ``walk_factor`` and invasion only (``calibration``); idle crews stand where they
are (on the pymunk floor the navigator moves them out of busy areas); stage 1 (the low
level's reaching, its rewards and rays) needs the pymunk floor.
"""

from __future__ import annotations

import bisect
import hashlib
import math

from .. import construct, decide
from ..cases.model import Case
from ..engine import Engine
from ..evaluate import TargetEvaluator
from ..motion import Span, crew_states, registered_motions, tick_reach_clock
from ..physics import N_KINDS
from ..policy import best_target
from ..state import TASKING, CrewState, Site
from .calibration import Calibration, uncalibrated
from .walks import Walk, WalkPlanner, congestion_areas

FIDELITIES = ("pymunk", "event")  # the motions shipped: the paper's, this one


def fidelities() -> tuple[str, ...]:
    """The names ``make_floor`` (and ``--fidelity``) takes: the shipped motions, then those
    registered (``motion.register_motion``)."""
    return FIDELITIES + tuple(registered_motions())


class EventPlane:
    """The plane of the event floor (``physics.Physics``' members the engine's stages use):
    crews are points, placed by their walks; nothing collides and no ray is cast."""

    at_rest = True

    def __init__(self, case: Case, site: Site):
        self.motion_version = 0
        self.storage_rects = {s.target: s.rect for s in site.storages}
        self.xy = [(c.start_x_m, c.start_y_m) for c in case.crews]
        self.headings = [math.radians(c.start_heading_deg) for c in case.crews]

    def pose(self, i: int) -> tuple[float, float, float]:
        return (*self.xy[i], self.headings[i])

    def place(self, i: int, xy: tuple[float, float], heading: float | None = None) -> None:
        self.xy[i] = xy
        if heading is not None:
            self.headings[i] = heading
        self.motion_version += 1

    def velocity(self, i: int) -> tuple[float, float]:
        return (0.0, 0.0)

    def drive(self, i: int, vx: float, vy: float, omega: float) -> None:
        """Crews walk their paths; there is nothing to drive."""

    def step(self, dt: float, substeps: int) -> None:
        """Nothing to step: the walk motion places the crews (``WalkMotion.move``)."""

    def take_contacts(self, i: int) -> list[int]:
        return [0] * N_KINDS

    def add_task_area(self, task: int, rect) -> None:
        self.motion_version += 1

    def remove_task_area(self, task: int) -> None:
        self.motion_version += 1

    def lay_deck(self, component: int) -> None:
        """Walks read the laid decks off the site (``walks.WalkPlanner``)."""
        self.motion_version += 1

    def remove_crew(self, i: int) -> None:
        """Points leave nothing behind."""

    def return_crew(self, i: int) -> None:
        """Nor come back to anything."""

    def ray_query(self, i: int):
        raise ValueError("the event floor casts no rays (Eq. 3): a low level that reads rays "
                         "needs the pymunk floor; fix: use fidelity 'pymunk'")

    def rebuild(self) -> None:
        """Nothing to rebuild: the plane is plain data."""


# one walk planner per case (by identity; the case is kept so that its id stays its own),
# shared by every event floor of it, their clones and later episodes: paths depend on the
# case alone, and planning them is most of a first floor's time
_PLANNERS: dict[int, tuple[Case, WalkPlanner]] = {}


_BY_CONTENT: dict[str, WalkPlanner] = {}  # the case's content (JSON) hashed -> its planner


def planner_for(case: Case, site: Site) -> WalkPlanner:
    """The case's shared walk planner (made on first use). Its paths depend on the case
    alone, so a case loaded again (another object, the same content: each test, each
    ``cmdp-evaluate`` strategy that loads the file) finds the planner and the fields planned
    for it before; looked up by the object first (every floor's reset asks)."""
    held = _PLANNERS.get(id(case))
    if held is None or held[0] is not case:
        digest = hashlib.sha256(case.model_dump_json().encode()).hexdigest()
        planner = _BY_CONTENT.get(digest)
        if planner is None:
            if len(_BY_CONTENT) >= 16:  # many cases in one process (a sweep of layouts)
                _BY_CONTENT.clear()
            planner = _BY_CONTENT[digest] = WalkPlanner(site)
        if len(_PLANNERS) >= 16:
            _PLANNERS.clear()
        held = _PLANNERS[id(case)] = (case, planner)
    return held[1]


class WalkMotion:
    """The event floor's motion (see the module doc): a span runs to the next event; a crew
    that holds target values walks to the best of them along the shortest path, in the time
    Eq. 1 gives along it times the calibrated walk factor; Eq. 2's invasion is the crew
    type's calibrated expectation. ``calibration``: the fitted numbers
    (``calibration.calibration_for``); None: the uncalibrated ones (walk factor 1, no
    invasion). Stage 2 only."""

    name = "event"
    takes_actions = False

    def __init__(self, calibration: Calibration | None = None):
        self._calibration = calibration
        self.planner: WalkPlanner | None = None
        self.walks: list[Walk | None] = []
        # per crew, the (values, scope) its walk was last chosen by (``replan``)
        self._chosen_by: list[tuple | None] = []
        self._fitted: dict = {}
        self._settled: dict | None = None  # the last table's ``decide.Context.settled``
        self._disruption_edges: tuple | None = None  # (windows, their edges): see its use

    @property
    def calibration(self) -> Calibration | None:
        """The fitted numbers the floor runs on (``calibration.calibration_for``)."""
        return self._calibration

    # -- the motion's members (``motion.Motion``) ---------------------------------------------

    def plane(self, case: Case, site: Site) -> EventPlane:
        self.planner = planner_for(case, site)
        return EventPlane(case, site)

    def check(self, engine: Engine) -> None:
        if engine.stage != 2:
            raise ValueError("the event floor runs stage 2 only: stage 1 trains the low "
                             "level's reaching (rays, contacts, rewards), which needs the "
                             "pymunk floor; fix: use fidelity 'pymunk' (cmdp_pymunk.Engine)")
        if self._calibration is None:
            self._calibration = uncalibrated(engine.case)
        # each crew type's numbers, looked up at every event (Eq. 2's invasion, the walks)
        self._fitted = {t: self._calibration.of(t) for t in engine.case.crew_types}

    def begin(self, engine: Engine) -> None:
        self.walks = [None] * len(engine.case.crews)
        self._chosen_by = [None] * len(engine.case.crews)
        self._settled = None

    def quiet(self, engine: Engine) -> bool:
        """Never: a span ends at an event, where the table always runs."""
        return False

    def needs_action(self, engine: Engine, crew: CrewState) -> bool:
        """No crew ever needs a reaching action: crews walk their paths."""
        return False

    def invasion_of(self, site: Site, positions, crew: CrewState, area) -> float:
        """Eq. 2's n * I_agent on the event floor: the crew type's calibrated expectation."""
        fitted = self._fitted[crew.type]
        return fitted.task_invasion if crew.status == TASKING else fitted.fetch_invasion

    def span_s(self, engine: Engine) -> int:
        """Whole seconds to the next event (at least 1; see the module doc)."""
        site = engine.site
        now = site.time_s
        ctx = engine.context()
        # the crews the table settled at the last event need no second look (``settled``)
        settled, self._settled = self._settled, None
        if not decide.only_execution_fires(ctx, settled):
            return 1
        soonest = min(engine.max_time_s - now,
                      construct.next_change_in(site, engine.positions, self.invasion_of,
                                               engine.lift_levels))
        every = site.case.simulation.reevaluate_after_steps
        walks = self.walks
        for crew in site.crews:
            walk = walks[crew.index]
            if walk is None or not crew.moving:
                continue
            if walk.arrival_s > now:
                soonest = min(soonest, walk.arrival_s - now)
            if crew.scope:
                soonest = min(soonest, every - crew.steps_since_reach % every)
        if engine.timeline is not None:
            soonest = min(soonest, self._next_disruption_change(engine, now) - now)
        if engine.stall_s is not None and not site.disrupted:
            soonest = min(soonest, engine.progress_mark[0] + engine.stall_s - now)
        return max(1, math.ceil(soonest - 1e-9))

    def move(self, engine: Engine, actions, span: Span) -> None:
        """The walkers ``span.seconds`` on along their paths (and their reach clocks); the
        span is counted by the state it began in (nothing changes until its last second)."""
        site, k = engine.site, span.seconds
        span.states = crew_states(site)
        now, then = site.time_s, site.time_s + k
        cap = site.case.simulation.reevaluate_after_steps
        positions, world, walks = engine.positions, engine.world, self.walks
        moving, had_target = span.moving, span.had_target  # as the crews stand now
        for crew in site.crews:
            i = crew.index
            walk = walks[i]
            if walk is None or not moving[i]:
                had_target[i] = False
                continue
            if crew.scope:
                walked = walk.distance_at(now)  # asked at the last event (kept there)
                span.distance_m[i] = walk.distance_at(then) - walked
                span.timeouts[i] = tick_reach_clock(crew, k, cap)
            else:
                had_target[i] = False
            xy = walk.at(then)
            positions[i] = xy
            world.place(i, xy, walk.heading())

    def position_due(self, engine: Engine, crew: CrewState) -> bool:
        """At each event, for a crew on its walk (between events its place is its path's)."""
        return self.walks[crew.index] is not None

    def end_span(self, engine: Engine, span: Span, ctx) -> None:
        self._settled = ctx.settled  # for the next event's look at the table (``settled``)
        if span.disrupted:  # the stall guard does not count a disruption's
            # seconds: on the pymunk floor its mark moved every one of them, up to the last
            engine.progress_mark = (engine.site.time_s - 1, engine.task_progress())
        self.replan(engine)

    def replan(self, engine: Engine) -> None:
        """Each crew on the move heads for its best target: a new walk from where it stands
        when that target changed (or it has none yet); none for a crew without values."""
        site, walks, chosen_by = engine.site, self.walks, self._chosen_by
        areas = None  # the areas that slow walks now: one event's walks share them
        for crew in site.crews:
            i = crew.index
            if not crew.moving:
                walks[i] = None
                continue
            walk = walks[i]
            values, scope = crew.values, crew.scope
            # the values and scope its walk was chosen by (a crew's dicts are replaced, never
            # changed in place): the same best target, asked for every crew at every event
            by = chosen_by[i]
            if walk is not None and by is not None and by[0] is values and by[1] is scope:
                continue
            target = best_target(crew)
            if target < 0:
                # values asked from outside come before any time passes: the walk holds until
                # they do (so values from outside run as the same rule injected)
                if i not in engine.pending:
                    walks[i] = None
                continue
            task = scope.get(target, -1)
            if walk is None or walk.target != target or walk.task != task:
                fitted = self._fitted[crew.type]
                if areas is None:
                    areas = congestion_areas(site)
                walks[i] = self.planner.walk(site, crew, engine.positions[i], target,
                                             site.time_s, fitted.walk_factor, fitted.dock_s,
                                             areas)
            chosen_by[i] = (values, scope)

    def _next_disruption_change(self, engine: Engine, now: float) -> float:
        """The next whole second at which a disruption window opens or closes."""
        # The whole seconds at which windows open or close, sorted, kept while the timeline
        # holds the same windows (``Timeline.resample`` gives an entry new ones): asked at
        # every event, they were a loop over every window.
        windows = [entry.windows for entry in engine.timeline.entries]
        held = self._disruption_edges
        if held is None or len(held[0]) != len(windows) or any(
                a is not b for a, b in zip(held[0], windows, strict=True)):
            edges = sorted({math.ceil(t) for w in windows for a, b in w for t in (a, b)})
            held = self._disruption_edges = (windows, edges)
        edges = held[1]
        i = bisect.bisect_right(edges, now)
        return edges[i] if i < len(edges) else math.inf


class EventFloor(Engine):
    """An engine on the walk motion (``WalkMotion``): the event floor. Nothing of its own but
    the constructor: ``EventFloor(case, ..., calibration=c)`` is ``Engine(case, ...,
    motion=WalkMotion(c))``. Stage 2 only; ``park_idle`` has no meaning here (no crew is
    driven) and is ignored."""

    def __init__(self, case: Case, stage: int = 2,
                 evaluator: TargetEvaluator | str | None = None,
                 seed: int | None = None, max_time_s: float | None = None,
                 park_idle: bool = False, stall_s: float | None = None,
                 position_log_every_s: float | None = None, *,
                 calibration: Calibration | None = None, logistics=None):
        super().__init__(case, stage, evaluator, seed, max_time_s, False, stall_s,
                         position_log_every_s, motion=WalkMotion(calibration),
                         logistics=logistics)


def make_floor(case: Case, fidelity: str = "pymunk", calibration: Calibration | None = None,
               **kwargs) -> Engine:
    """A floor of ``case``: ``"pymunk"`` (the paper's, the physics motion; the default and
    the ground truth) or ``"event"`` (the walk motion, ``WalkMotion``; ``calibration`` its
    numbers). ``kwargs`` go to the engine (stage, evaluator, max_time_s, stall_s,
    park_idle...). A bad name: a ValueError naming the choices."""
    if fidelity == "pymunk":
        return Engine(case, **kwargs)
    if fidelity == "event":
        kwargs.pop("park_idle", None)
        return EventFloor(case, calibration=calibration, **kwargs)
    factory = registered_motions().get(fidelity)
    if factory is not None:
        return Engine(case, motion=factory(calibration), **kwargs)
    raise ValueError(f"fidelity {fidelity!r} is not one of {', '.join(fidelities())}; fix: "
                     "'pymunk' (the paper's floor, the default) or 'event' (the event floor, "
                     "fast, calibrated on pymunk)")


__all__ = ["EventFloor", "EventPlane", "WalkMotion", "make_floor", "FIDELITIES", "fidelities"]
