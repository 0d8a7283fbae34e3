"""The event floor: the CMDP's construction process jumping from event to event.

The same case, construction state (``state.Site``), decision table (Table 1, ``decide``),
P_cons (``construct``, Eq. 2), crane queue, precedence, random streams (a task's pace is the
one it draws on the pymunk floor on the same seed), disruptions (``disruptions``), event log
and evaluators as the pymunk floor (``engine.Engine``, which this is a subclass of), but no
per-second physics and no low level: a crew that holds target values walks to the best of
them (``steering.best_target``'s rule: highest V_Tar, lowest index on ties) along the shortest
path, in the time Eq. 1 gives along it (``walks``), and arrives at a whole second.

Between two events every rate is constant (task paces under the calibrated invasion of
Eq. 2, loading rates, the crane's countdown, the walks), so the floor jumps to the next
second at which anything can change and runs there exactly what the pymunk engine runs at the
end of a second: P_cons for the seconds jumped (``construct.advance`` with ``dt`` of many
seconds), disruptions, the decision table, the target evaluation, the event log. Events:

- a task ends, or its crew's load runs out (c9, c3); a load is full, or the storage empty (c6,
  c7), or down to its material's reorder point (``construct.reorder``); the crane's lift or
  assistance is done;
- a walk arrives (c1, c4, c5, c7, the outlet);
- a disruption starts or ends (``disruptions.Timeline``), and a walker's re-evaluation is due
  (``reevaluate_after_steps`` seconds without a reach, section 3.6);
- a row of the table would fire in the next second (``decide.only_execution_fires`` false):
  what the pymunk engine would do a second later happens a second later here too (a crew
  whose scope went stale re-acquires).

The loop is a plain one over "the next event" rather than SimPy's processes: every event time
follows from the state at the last event (nothing here waits on a resource but the crane,
whose queue is the site's), and a floor must branch (``clone``): a heap of generators cannot
be copied, a site can. Crews walking when the site changes re-value (c10 and the evaluator,
with where they are along the path now) and turn to a new best target from there.

What it is not: crews are points on their paths, so contacts, swerving and jams are in the
calibrated ``walk_factor`` and invasion only (``calibration``); idle crews stand where they
are (on the pymunk floor the navigator moves them out of busy areas); stage 1 (the low
level's reaching, its rewards and rays) needs the pymunk floor.
"""

from __future__ import annotations

import bisect
import copy
import math

from .. import construct, decide, disruptions, events, reward
from ..cases.model import Case
from ..engine import Advance, Engine
from ..evaluate import TargetEvaluator
from ..physics import N_KINDS
from ..policy import best_target
from ..state import FETCHING, REACHING, TASKING, WAITING, CrewState, Site
from .calibration import Calibration, uncalibrated
from .walks import Walk, WalkPlanner

FIDELITIES = ("pymunk", "event")  # what ``make_floor`` builds: the paper's floor, this one


class EventPlane:
    """The plane of the event floor (``physics.Physics``' members the engine's stages use):
    crews are points, placed by the floor; nothing collides and no ray is cast."""

    at_rest = True

    def __init__(self, case: Case, site: Site, planner: WalkPlanner):
        self.planner = planner
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
        raise RuntimeError("the event floor has no physics to step; it jumps between events "
                           "(EventFloor.advance)")

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


class _Planes:
    """Builds an episode's ``EventPlane`` on the case's shared walk planner."""

    def __call__(self, case: Case, site: Site) -> EventPlane:
        held = _PLANNERS.get(id(case))
        if held is None or held[0] is not case:
            if len(_PLANNERS) >= 16:  # many cases in one process (a sweep of layouts)
                _PLANNERS.clear()
            held = _PLANNERS[id(case)] = (case, WalkPlanner(site))
        return EventPlane(case, site, held[1])

    def __deepcopy__(self, memo):
        return self


def _never() -> bool:
    return False


class EventFloor(Engine):
    """The event floor (see the module doc): an ``Engine`` whose ``advance`` jumps from event
    to event. ``calibration``: the fitted numbers (``calibration.calibration_for``); None: the
    uncalibrated ones (walk factor 1, no invasion). Stage 2 only."""

    fidelity = "event"
    needs_low_level = False

    def __init__(self, case: Case, stage: int = 2,
                 evaluator: TargetEvaluator | str | None = None,
                 seed: int | None = None, max_time_s: float | None = None,
                 park_idle: bool = False, stall_s: float | None = None,
                 position_log_every_s: float | None = None, *,
                 calibration: Calibration | None = None):
        if stage != 2:
            raise ValueError("the event floor runs stage 2 only: stage 1 trains the low "
                             "level's reaching (rays, contacts, rewards), which needs the "
                             "pymunk floor; fix: use fidelity 'pymunk' (cmdp_pymunk.Engine)")
        super().__init__(case, 2, evaluator, seed, max_time_s, False, stall_s,
                         position_log_every_s, physics=_Planes())
        self.calibration = calibration if calibration is not None else uncalibrated(case)
        self.walks: list[Walk | None] = []
        self.events_run = 0  # events jumped to this episode (the speed benchmark's count)
        self._settled: dict | None = None  # the last table's ``decide.Context.settled``
        self._disruption_edges: tuple | None = None  # (windows, their edges): see its use

    @property
    def calibration(self) -> Calibration:
        """The fitted numbers the floor runs on (``calibration.calibration_for``)."""
        return self._calibration

    @calibration.setter
    def calibration(self, value: Calibration) -> None:
        self._calibration = value
        # each crew type's numbers, looked up at every event (Eq. 2's invasion, the walks)
        self._fitted = {t: value.of(t) for t in self.case.crew_types}

    # -- an episode ---------------------------------------------------------------------------

    def reset(self, seed: int | None = None) -> None:
        self.walks = [None] * len(self.case.crews)
        self.events_run = 0
        self._settled = None
        super().reset(seed)
        self._plan_walks()

    def needs_action(self, crew: CrewState) -> bool:
        """No crew ever needs a reaching action: crews walk their paths."""
        return False

    def step(self, actions=None):
        raise RuntimeError("the event floor does not step second by second; call "
                           "advance(None, until) (it jumps to the next event)")

    def advance(self, actions=None, until=None) -> Advance:
        """Jump from event to event until ``until()`` holds after one (None: one event),
        every task has ended, or the time limit or the stall guard cuts the episode; a crew
        that waits for values from outside (``pending``) stops it too. ``actions`` are
        ignored (there is no low level)."""
        if self.pending:
            raise RuntimeError(f"crews {self.pending} wait for target values; call "
                               "set_target_values for each first")
        site = self.site
        out = Advance(rewards=[0.0] * len(site.crews))
        self.metrics.open_window()
        self._plan_walks()  # values may have come from outside
        truncated = False
        while True:
            k = self._next_event_in()
            self._jump(k, out)
            truncated = site.time_s >= self.max_time_s - 1e-9 or self._stall_check()
            if site.done or truncated or until is None or until() or self.pending:
                break
        self.metrics.close_window()
        out.terminated = site.done
        out.truncated = truncated
        if not (out.terminated or out.truncated):
            self._value_between_seconds()
            self._plan_walks()
        return out

    def run(self) -> Advance:
        """To the end of the episode (every task ended, the time limit or the stall guard),
        valuing between events if the evaluator asks so."""
        total = Advance(rewards=[0.0] * len(self.site.crews))
        while True:
            part = self.advance(None, until=_never)
            total.elapsed += part.elapsed
            for k, v in part.terms.items():
                total.terms[k] += v
            if part.terminated or part.truncated:
                total.terminated, total.truncated = part.terminated, part.truncated
                return total

    @classmethod
    def from_engine(cls, engine: Engine, calibration: Calibration | None = None,
                    keep_log: bool = False) -> EventFloor:
        """An event floor at the state of any floor (the pymunk one at a decision): its site,
        crews where they stand, the event log (if ``keep_log``), counters, streams,
        disruptions and evaluator; crews that were walking walk on from where they are to
        their best target. A planner thinks on it and acts on the pymunk floor."""
        if engine.site is None:
            raise RuntimeError("from_engine: the engine has no episode yet; call reset first")
        floor = cls(engine.case, 2, None, max_time_s=engine.max_time_s,
                    stall_s=engine.stall_s, position_log_every_s=None,
                    calibration=calibration)
        memo = {id(engine.case): engine.case}
        if engine.evaluator is not None:
            memo[id(engine.evaluator)] = engine.evaluator
        if not keep_log:
            memo[id(engine.log)] = events.EventLog()
        for name in ("site", "log", "metrics", "streams", "timeline", "pending", "activities",
                     "steps", "stalled", "_last_logged", "_no_rewards", "_progress_mark",
                     "_terms"):
            setattr(floor, name, copy.deepcopy(getattr(engine, name), memo))
        floor._evaluator = engine.evaluator
        floor.world = floor.physics(floor.case, floor.site)
        n = len(floor.site.crews)
        floor.positions = [tuple(engine.positions[i]) for i in range(n)]
        for i in range(n):
            x, y, heading = engine.pose(i)
            floor.world.place(i, (x, y), heading)
        floor.memory = {}
        floor.action_needed = False
        floor.walks = [None] * n
        floor._plan_walks()
        return floor

    # -- the events ---------------------------------------------------------------------------

    def _invasion(self, site: Site, positions, crew: CrewState, area) -> float:
        """Eq. 2's n * I_agent on the event floor: the crew type's calibrated expectation."""
        fitted = self._fitted[crew.type]
        return fitted.task_invasion if crew.status == TASKING \
            else fitted.fetch_invasion

    def _next_event_in(self) -> int:
        """Whole seconds to the next event (at least 1; see the module doc)."""
        site = self.site
        now = site.time_s
        ctx = self._context()
        # the crews the table settled at the last event need no second look (``settled``)
        settled, self._settled = self._settled, None
        if not decide.only_execution_fires(ctx, settled):
            return 1
        soonest = self.max_time_s - now
        disrupted = site.disrupted
        weather = bool(disrupted) and disrupted.weather
        drain: dict[int, float] = {}  # storage -> loading rate of the crews at it
        for crew in site.crews:
            if crew.absent:
                continue
            if crew.status == TASKING and not weather:
                task = site.tasks[crew.task]
                if not (construct.crane_ready(task) and construct.material_sufficient(
                        crew, task)) or task.progress >= task.work - construct.EPS:
                    continue
                rate = construct.invaded_efficiency(task.pace, self._invasion(
                    site, self.positions, crew, task.area))
                if rate <= 0.0:
                    continue
                left = (task.work - task.progress) / rate
                if task.material_per_work > 0.0:
                    left = min(left, crew.load / (task.material_per_work * rate))
                soonest = min(soonest, left)
            elif crew.status == FETCHING and not weather:
                storage = site.storages[crew.storage]
                rate = construct.invaded_efficiency(
                    site.case.materials[storage.material].acquire_per_min / 60.0,
                    self._invasion(site, self.positions, crew, storage.rect))
                if rate <= 0.0:
                    continue
                soonest = min(soonest, (crew.capacity - crew.load) / rate)
                drain[storage.index] = drain.get(storage.index, 0.0) + rate
            walk = self.walks[crew.index] if crew.moving else None
            if walk is not None and walk.arrival_s > now:
                soonest = min(soonest, walk.arrival_s - now)
            if walk is not None and crew.scope:
                every = site.case.simulation.reevaluate_after_steps
                soonest = min(soonest, every - crew.steps_since_reach % every)
        for s, rate in drain.items():
            storage = site.storages[s]
            soonest = min(soonest, storage.stock / rate)
            at = site.case.materials[storage.material].reorder_at
            if at > 0.0 and not storage.lift_pending and storage.stock > at + construct.EPS:
                soonest = min(soonest, (storage.stock - at) / rate)  # its reorder point
        crane = site.crane
        if crane.current is not None and not (disrupted and disrupted.crane_stopped()):
            soonest = min(soonest, crane.remaining_s)
        if self.timeline is not None:
            soonest = min(soonest, self._next_disruption_change(now) - now)
        if self.stall_s is not None and not site.disrupted:
            soonest = min(soonest, self._progress_mark[0] + self.stall_s - now)
        return max(1, math.ceil(soonest - 1e-9))

    def _next_disruption_change(self, now: float) -> float:
        """The next whole second at which a disruption window opens or closes."""
        # The whole seconds at which windows open or close, sorted, kept while the timeline
        # holds the same windows (``Timeline.resample`` gives an entry new ones): asked at
        # every event, they were a loop over every window.
        windows = [entry.windows for entry in self.timeline.entries]
        held = self._disruption_edges
        if held is None or len(held[0]) != len(windows) or any(
                a is not b for a, b in zip(held[0], windows, strict=True)):
            edges = sorted({math.ceil(t) for w in windows for a, b in w for t in (a, b)})
            held = self._disruption_edges = (windows, edges)
        edges = held[1]
        i = bisect.bisect_right(edges, now)
        return edges[i] if i < len(edges) else math.inf

    def _jump(self, k: int, out: Advance) -> None:
        """``k`` seconds on: walkers move along their paths, P_cons runs them through, then
        the end of a second as the pymunk engine runs it (disruptions, Table 1, values,
        causes, the log, R_e's terms)."""
        site = self.site
        self.events_run += 1
        disrupted_span = bool(site.disrupted)  # the seconds jumped over were disrupted
        self._count(k)
        terms_before = self._terms
        site.time_s += k
        self.steps += k
        for crew in site.crews:  # where the walkers are now
            walk = self.walks[crew.index]
            if walk is not None and crew.moving:
                xy = walk.at(site.time_s)
                self.positions[crew.index] = xy
                self.world.place(crew.index, xy, walk.heading())
                if crew.scope:
                    crew.steps_since_reach += k
        logged = len(self.log.events)
        construct.advance(site, self.positions, self.log, float(k), self._invasion)
        self._construct_logged = len(self.log.events) != logged
        self._disrupt()
        ctx = self._context()
        self._decide(ctx)
        self._settled = ctx.settled  # for the next event's look at the table (``settled``)
        if self.timeline is not None:
            disruptions.refresh_causes(site)
        self._log_activities()
        self._log_positions()
        self._terms = self._reward_terms()
        for name, v in terms_before.items():
            out.terms[name] += v * (k - 1) + self._terms[name]
        out.elapsed += k
        if disrupted_span:  # the stall guard does not count a disruption's seconds: on the
            # pymunk floor its mark moved every one of them, up to the last
            self._progress_mark = (site.time_s - 1, self._task_progress())
        self._plan_walks()

    def _reward_terms(self) -> dict[str, float]:
        return reward.evaluation_reward_terms(self.site, self.case.evaluation_reward)

    def _count(self, k: int) -> None:
        """The counters (``metrics``) for ``k`` seconds of the state as it stands."""
        stats_cap = self.metrics.reach_cap
        for crew in self.site.crews:
            stats = crew.stats
            if crew.disruption:
                stats.idle_steps[crew.disruption] += k
            if crew.moving:
                walk = self.walks[crew.index]
                if crew.scope and walk is not None:
                    stats.reaching_steps += k
                    self.metrics.window[crew.index]["reaching"] += k
                    before = crew.steps_since_reach
                    timeouts = (before + k) // stats_cap - before // stats_cap
                    stats.reach_timeouts += timeouts
                    self.metrics.window[crew.index]["timeouts"] += timeouts
                    now = self.site.time_s
                    walked = walk.distance_at(now)  # asked at the last event (kept there)
                    stats.distance_m += walk.distance_at(now + k) - walked
                elif crew.status == REACHING and crew.idle_cause:
                    stats.idle_steps[crew.idle_cause] += k
            elif crew.status == WAITING:
                stats.crane_wait_steps += k

    def _log_positions(self) -> None:
        """``position`` events of the crews on the move, at each event (not every
        ``position_log_every_s``: between events a crew's place is its path's), so that
        trajectories can be drawn; none unless ``position_log_every_s`` is set."""
        if self.position_log_every_s is None or not self.walks:
            return
        for crew in self.site.crews:
            if self.walks[crew.index] is not None and crew.moving:
                self._log_position(crew)  # the plane holds where it is on its walk

    def _plan_walks(self) -> None:
        """Each crew on the move heads for its best target: a new walk from where it stands
        when that target changed (or it has none yet); none for a crew without values."""
        site = self.site
        for crew in site.crews:
            i = crew.index
            if not crew.moving:
                self.walks[i] = None
                continue
            target = best_target(crew)
            walk = self.walks[i]
            if target < 0:
                # values asked from outside come before any time passes: the walk holds until
                # they do (so values from outside run as the same rule injected)
                if i not in self.pending:
                    self.walks[i] = None
                continue
            task = crew.scope.get(target, -1)
            if walk is not None and walk.target == target and walk.task == task:
                continue
            fitted = self._fitted[crew.type]
            self.walks[i] = self.world.planner.walk(site, crew, self.positions[i], target,
                                                    site.time_s, fitted.walk_factor,
                                                    fitted.dock_s)


def make_floor(case: Case, fidelity: str = "pymunk", calibration: Calibration | None = None,
               **kwargs) -> Engine:
    """A floor of ``case``: ``"pymunk"`` (the paper's, ``engine.Engine``; the default and the
    ground truth) or ``"event"`` (``EventFloor``; ``calibration`` its numbers). ``kwargs`` go
    to the floor (stage, evaluator, max_time_s, stall_s, park_idle...). A bad name: a
    ValueError naming the choices."""
    if fidelity == "pymunk":
        return Engine(case, **kwargs)
    if fidelity == "event":
        kwargs.pop("park_idle", None)
        return EventFloor(case, calibration=calibration, **kwargs)
    raise ValueError(f"fidelity {fidelity!r} is not one of {', '.join(FIDELITIES)}; fix: "
                     "'pymunk' (the paper's floor, the default) or 'event' (the event floor, "
                     "fast, calibrated on pymunk)")


__all__ = ["EventFloor", "EventPlane", "make_floor", "FIDELITIES"]
