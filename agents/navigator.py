"""The scripted navigator: drives each crew to its highest-value target with reaching actions.

It is the low level until a trained one exists, and afterwards the yardstick the trained one is
measured against. It reads the engine's state (not the rays) and answers with the same
``MultiDiscrete([4, 3, 3])`` actions the learned policy uses.

How it plans: the plane is a grid (``cell_m``); for each crew size, cells closer to a component
or wall than the crew's radius plus ``clearance_m`` are blocked, less the bridges where the
crew passes between them (``cmdp_pymunk.cases.reach.free_cells``: the cells the case check
proves on). The default clearance is
negative (-0.2 m) so that every lane a crew fits through keeps at least one row of free cells at
this resolution; the contact solver keeps the crew off the component, and crews slide along
it (no friction). A cost-to-go field to the target's reach region
(the task area, the storage, the outlet) is computed with Dijkstra over the free cells, with
active task areas and stocked storages costing more to cross (they slow a crew, Eq. 1, and
entering them is penalised, Eq. 6). Fields are cached per target and re-planned whenever task
areas appear or vanish. A crew follows the field's steepest descent a few cells ahead.

How it moves: turn toward that point, walk when roughly facing it, side-step for small
offsets; swerve from crews ahead (keeping right). A crew without a target stands still, unless
it stands in an active task area or a storage, which it leaves.

When it makes no progress (issue 31: "a navigator that cannot get stuck for an hour").
Progress is a drop in the crew's cost-to-go to its target (on the field it follows; in the
approach band, its distance to the task area), not raw displacement, so pacing back and forth
at a blocked lane counts as none. An escalation ladder,
each rung firing only when the one below has had its chance:

1. after ``STUCK_STEPS`` steps without progress: re-plan around the other crews' current
   positions for ``DETOUR_STEPS`` steps (the first rule, which the golden schedules were
   recorded with; it repeats);
2. after ``BACK_OFF_AFTER_S`` s: back off, a few metres away from the crews around it, for
   ``BACK_OFF_S`` s, then try again; and ask the parked crews next to it (no target, standing
   for good: perhaps waiting for the very task it walks to) to make way, each to a free cell
   a few metres off (``Engine.make_way`` lets a parked crew move for ``MAKE_WAY_S`` s);
3. after ``DETOUR_AFTER_S`` s: take a detour that prices the places it got stuck at and the
   crews standing still (working, waiting or without a target) as obstacles, and keep to it
   until it reaches or gets stuck on it too (then the ladder starts again on the detour);
   parked crews next to it are asked aside again;
4. after ``GIVE_UP_AFTER_S`` s: give up on this way: walk to a free cell some metres away,
   drawn from the crew's index and the time (the same floor gives the same schedule), for up
   to ``LONG_BACK_OFF_S`` s, then plan afresh.

The clock restarts where a crew is not stuck: where it reaches its target (waiting there to
start), and after a gap in its decisions (the floor jumps idle time only while
no crew walks). Rungs 2-4 fire only where rung 1 has failed for minutes, which no crew of the
golden schedules (``tests/test_golden.py``) ever does (the longest spell without progress on
the built-in floor's seeds 0-4 is 95 s): those schedules are unchanged. The stall guard
(``Engine.stall_s``) stays the last resort; ``way(engine, i)`` gives the cells a crew means
to walk, for the stall report's picture.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from cmdp_pymunk.cases.reach import (
    APPROACH_BAND_M,
    CELL_M,
    CLEARANCE_M,
    NEIGHBOURS,
    PlaneGrid,
    area_points,
    free_cells,
)
from cmdp_pymunk.geometry import Outline
from cmdp_pymunk.move import STAND_STILL
from cmdp_pymunk.state import CrewStatus, ScopeKind, inside

from .steering import best_target

AREA_COST = 4.0  # crossing an active task area costs this much more than open floor
STORAGE_COST = 1.5
LOOKAHEAD_CELLS = 4
STUCK_STEPS = 12  # no progress for this many steps: re-plan around the crews
STUCK_PROGRESS_M = 0.3
DETOUR_STEPS = 40
# The escalation ladder (module doc): seconds without progress before each rung. The golden
# floors' longest spell without progress is far below BACK_OFF_AFTER_S (see its test).
LADDER_PROGRESS_M = 0.5  # a drop in cost-to-go this large (m of open floor) is progress
BACK_OFF_AFTER_S = 120.0
BACK_OFF_S = 12.0
BACK_OFF_M = (1.5, 4.0)  # how far a back-off goes: out of the jam, not out of the way
DETOUR_AFTER_S = 240.0
STUCK_SPOT_M = 1.0  # beyond the crew's radius: how much of a stuck place a detour avoids
GIVE_UP_AFTER_S = 600.0
LONG_BACK_OFF_S = 90.0
LONG_BACK_OFF_M = (4.0, 12.0)
MAKE_WAY_GAP_M = 1.5  # a parked crew this close (edge to edge) to a stuck one is asked aside
MAKE_WAY_M = (3.0, 8.0)
MAKE_WAY_S = 90.0
OBSTACLE_COST = 1e4  # passable at a price: a detour is never trapped by what it avoids
WAY_CELLS = 400  # the most cells ``way`` traces


class _Grid:
    """Free cells and their 8-connected edges for one crew radius, on the plane's grid
    (``cmdp_pymunk.cases.reach.PlaneGrid``, the one the case check proves reachable), with
    the decks laid so far open floor."""

    def __init__(self, nav: _Plans, radius: float):
        self.radius = radius
        laid = nav.site.laid
        # the case check's cells (one reach rule: ``cases.reach.free_cells``)
        self.blocked = ~free_cells(
            nav.plane, [c.rect for c in nav.site.components if c.index not in laid], radius,
            nav.clearance_m)
        self.src, self.dst, self.length = nav.plane.edges(~self.blocked)
        self.n = nav.nx * nav.ny
        self.graphs: dict = {}
        self._layout = None  # (indices, indptr, order): the CSR form of these edges, once

    def __deepcopy__(self, memo):
        # Shared by a floor and its clones: the free cells depend on the case alone, and the
        # graph cache is a pure function of its key (the area state).
        return self

    def graph(self, cost: np.ndarray, key=None) -> csr_matrix:
        """The weighted graph for these cell costs; cached under ``key`` (the area state) if
        given. Personal detours pass no key: a key made from an object's id could be reused
        by a later object, and a stale graph would make runs differ."""
        g = self.graphs.get(key) if key is not None else None
        if g is None:
            c = cost.ravel()
            g = self._weighted(self.length * 0.5 * (c[self.src] + c[self.dst]))
            if key is not None:
                self.graphs = {key: g}  # one area state at a time
        return g

    def _weighted(self, w: np.ndarray) -> csr_matrix:
        """``csr_matrix((w, (src, dst)))``, the edges being the same every time: their CSR
        layout (sorted by source, then target) is found once and each new set of weights is
        laid into it, not sorted again (the same matrix, entry for entry: the edges are
        unique, so nothing is summed; a test compares the two)."""
        if self._layout is None:
            shape = (self.n, self.n)
            position = csr_matrix((np.arange(1, len(w) + 1, dtype=np.float64),
                                   (self.src, self.dst)), shape=shape)
            self._layout = (position.indices, position.indptr,
                            position.data.astype(np.int64) - 1)
        indices, indptr, order = self._layout
        return csr_matrix((w[order], indices, indptr), shape=(self.n, self.n))


@dataclasses.dataclass
class _Escape:
    """One crew's climb up the escalation ladder toward one target (module doc)."""

    target: int
    best: float  # the lowest cost-to-go reached on ``seen``
    since_s: float  # when it last made progress
    seen: object = None  # the field ``best`` was measured on (a new one is measured afresh)
    rung: int = 0  # rungs climbed since the last progress
    way: np.ndarray | None = None  # a detour the crew keeps to (rung 3), else its own field
    spots: list = dataclasses.field(default_factory=list)  # where it got stuck: avoided by detours
    retreat: tuple | None = None  # (field, until_s, fresh afterwards) of a back-off
    last_s: float = -math.inf  # when it was last asked for an action


class Navigator:
    """Scripted low level (``cmdp_pymunk.policy.LowLevel``): ``actions(engine)`` every second,
    by crew index. It reads the state, not the rays; its plans for an episode live in
    ``engine.memory["navigator"]`` (``_Plans``), so a clone of the floor carries them."""

    reads_rays = False
    MEMORY = "navigator"

    def __init__(self, cell_m: float = CELL_M, clearance_m: float = CLEARANCE_M):
        self.cell_m = cell_m
        self.clearance_m = clearance_m

    def bind(self, engine) -> None:
        """Fits every case (it plans on the engine's own plane)."""

    def reset(self, seed: int) -> None:
        """A new episode (after the engine's reset, which clears its plans): the navigator
        draws no random numbers, so the seed is not used."""

    def plans(self, engine) -> _Plans:
        """The episode's plans on ``engine`` (made on first use)."""
        plans = engine.memory.get(self.MEMORY)
        if plans is None:
            plans = engine.memory[self.MEMORY] = _Plans(engine, self.cell_m, self.clearance_m)
        return plans

    def actions(self, engine, observations=None) -> list:
        """Every crew's action, by crew index (the observations are not needed)."""
        return self.plans(engine).actions()

    def way(self, engine, i: int) -> list[tuple[float, float]]:
        """The cell centres (m) crew ``i`` means to walk from where it stands, down the field
        it follows (a detour or back-off if it is on one): for the stall report's picture.
        Empty for a crew that is not walking to a target."""
        return self.plans(engine).way(i)


class _Plans:
    """One episode's grids, cost-to-go fields and per-crew progress, for ``Navigator``."""

    def __init__(self, engine, cell_m: float, clearance_m: float):
        self.engine = engine
        self.cell_m = cell_m
        self.clearance_m = clearance_m
        self.site = engine.site
        self.plane = PlaneGrid.of(engine.case.plane.half_extents, cell_m)
        plane = self.plane
        self.half_w, self.half_h, self.nx, self.ny = plane.half_w, plane.half_h, plane.nx, \
            plane.ny
        self.cx, self.cy = plane.cx, plane.cy
        self._make_grids()
        self.fields: dict = {}
        self.area_key = None
        n = len(self.site.crews)
        self.best = [math.inf] * n
        self.since_progress = [0] * n
        self.detour = [None] * n  # (field, target, steps left)
        self.goal = [None] * n
        self.escape: list[_Escape | None] = [None] * n
        self.aside: dict[int, tuple[np.ndarray, float]] = {}  # parked crews making way
        self.rungs = {"back_off": 0, "make_way": 0, "detour": 0, "give_up": 0}  # fired
        self.work_points: dict = {}  # (radius, task, decks laid) -> the area's work points
        self.plans = 0

    def _make_grids(self) -> None:
        """A grid per crew radius on the floor open now (the decks laid so far)."""
        self.laid = self.site.laid
        self.grids: dict[float, _Grid] = {}
        self.crew_grid = []
        for crew in self.site.crews:
            r = round(crew.spec.radius_m, 3)
            if r not in self.grids:
                self.grids[r] = _Grid(self, r)
            self.crew_grid.append(self.grids[r])

    def _cost(self) -> np.ndarray:
        cost = np.ones((self.ny, self.nx))
        for t in self.site.active_areas:
            cost[self._rect_mask(self.site.tasks[t].area)] = AREA_COST
        for st in self.site.storages:  # stocked or not: stocks change too often to re-plan on
            cost[self._rect_mask(st.rect)] = np.maximum(cost[self._rect_mask(st.rect)],
                                                        STORAGE_COST)
        return cost

    def _rect_mask(self, rect, shrink: float = 0.0) -> np.ndarray:
        return self.plane.rect_mask(rect, shrink)

    def _goal_mask(self, crew, target: int) -> np.ndarray:
        site = self.site
        if target == site.outlet_target:
            plane = self.engine.case.plane
            return np.hypot(self.cx - plane.outlet_x_m, self.cy - plane.outlet_y_m) \
                <= plane.outlet_radius_m - 0.1
        n_comp = len(site.components)
        if target >= n_comp:
            return self._rect_mask(site.storages[target - n_comp].rect, 0.1)
        # A task area can be thinner than the crew is wide (JC: 1.2 m for a 1.13 m radius):
        # plan to a band around it, then close in on the component (``act``).
        return self._rect_mask(site.tasks[crew.scope[target]].area, -APPROACH_BAND_M)

    def _field(self, crew, target: int, extra_blocked: np.ndarray | None = None) -> np.ndarray:
        grid = self.crew_grid[crew.index]
        key = (grid.radius, target, crew.scope.get(target, -1))
        if extra_blocked is None and key in self.fields:
            return self.fields[key]
        self.plans += 1
        cost = self._cost()
        if extra_blocked is not None:
            cost = cost.copy()
            cost[extra_blocked] = 1e4  # passable at a price: never trapped by a crowd
        graph = grid.graph(cost, self.area_key if extra_blocked is None else None)
        goal = self._goal_mask(crew, target) & ~grid.blocked
        goals = np.flatnonzero(goal.ravel())
        if goals.size == 0:
            field = None
        else:
            field = dijkstra(graph, directed=False, indices=goals, min_only=True)
            field = field.reshape(self.ny, self.nx)
        if extra_blocked is None:
            self.fields[key] = field
        return field

    # -- acting -------------------------------------------------------------------------------

    def actions(self) -> list:
        """Every crew's action, by crew index."""
        if self.site.laid != self.laid:  # a deck was laid: plan over it from now on
            self._make_grids()
            self.area_key = None
        key = tuple(sorted(self.site.active_areas))
        if key != self.area_key:  # task areas appeared or vanished: re-plan everything
            self.area_key = key
            self.fields = {}
        return [self.act(crew) for crew in self.site.crews]

    def _cell(self, x: float, y: float) -> tuple[int, int]:
        return self.plane.cell(x, y)

    def act(self, crew):
        if not crew.moving:
            self.escape[crew.index] = None  # it reached, or works: a later walk starts afresh
            return STAND_STILL
        pose = self.engine.pose(crew.index)
        x, y = pose[0], pose[1]
        target = best_target(crew)
        if target < 0:
            self.escape[crew.index] = None
            return self._idle(crew, pose, x, y)
        if self.goal[crew.index] != target:
            self.goal[crew.index] = target
            self.best[crew.index] = math.inf
            self.since_progress[crew.index] = 0
            self.detour[crew.index] = None
        field = self._field(crew, target)
        if field is not None:
            point = self._escalate(crew, target, field, x, y)
            if point is not None:
                return self._drive(crew, pose, x, y, *point)
        detour = self.detour[crew.index]
        if detour is not None:
            field = detour[0]
            self.detour[crew.index] = (detour[0], detour[1] - 1) if detour[1] > 1 else None
            detoured = True
        else:
            detoured = False
        if field is None:
            tx, ty = self.site.target_xy[target]
            return self._drive(crew, pose, x, y, tx, ty)
        here = self._value(field, x, y)
        if here < self.best[crew.index] - STUCK_PROGRESS_M:
            self.best[crew.index] = here
            self.since_progress[crew.index] = 0
        else:
            self.since_progress[crew.index] += 1
            if self.since_progress[crew.index] >= STUCK_STEPS:
                self._replan_around_crews(crew, target)
                self.since_progress[crew.index] = 0
                self.best[crew.index] = math.inf
        if here == 0.0 and target < len(self.site.components):
            # in the approach band: close in on the component's nearest point, or, once the
            # crew has backed off stuck here, on the nearest work point
            point = self._work_point(crew, target, x, y) if self._stuck_before(crew, target) \
                else None
            if point is not None:
                px, py = point
            else:
                shape = self.site.components[target].rect
                if isinstance(shape, Outline):  # a polygon: its nearest point, not its box's
                    px, py = shape.nearest(x, y)
                else:
                    x0, y0, x1, y1 = shape
                    px, py = min(max(x, x0), x1), min(max(y, y0), y1)
        else:
            carrot = self._carrot(field, x, y, lowest=detoured)
            px, py = carrot if carrot is not None else self.site.target_xy[target]
        return self._drive(crew, pose, x, y, px, py)

    def _stuck_before(self, crew, target: int) -> bool:
        """Whether the crew has backed off stuck on its way to ``target`` (the ladder's spots,
        kept until a give-up starts it afresh)."""
        esc = self.escape[crew.index]
        return esc is not None and esc.target == target and bool(esc.spots)

    def _work_point(self, crew, target: int, x: float, y: float) -> tuple[float, float] | None:
        """The nearest point of the crew's task area at ``target`` where a crew of its radius
        fits among the components standing (``reach.area_points``: the case check's work
        points, where the event floor's walks end), or None where there is none.

        Why: the component's nearest point can lie behind another component. A crew that
        closes in on it from the band below a beam fencing a slab's edge presses against the
        beam, its centre short of the area, while the check's work point sits round the
        beam's corner (the fenced slabs with open corners, seed 41: JCC-1 pressed for 4,900 s,
        0.3 m short); the ladder's back-offs and detours all led back to the same spot."""
        task = crew.scope[target]
        key = (round(crew.spec.radius_m, 3), task, self.laid)
        points = self.work_points.get(key)
        if points is None:
            standing = [c.rect for c in self.site.components if c.index not in self.laid]
            _, px, py, ok = area_points(self.plane, self.site.tasks[task].area, standing,
                                        crew.spec.radius_m)
            points = self.work_points[key] = (px[ok], py[ok])
        px, py = points
        if px.size == 0:
            return None
        k = int(np.argmin(np.hypot(px - x, py - y)))
        return float(px[k]), float(py[k])

    def _value(self, field, x, y) -> float:
        i, j = self._cell(x, y)
        return field[j, i]

    def _carrot(self, field, x: float, y: float, lowest: bool = False) -> tuple[float, float]:
        """A point a few cells down the field's steepest descent from the crew.

        From a blocked cell (a crew pushed against a component) it heads for the nearest free
        cell; with ``lowest`` (on a detour), for the one lowest on the field among the nearest
        free cells: the nearest alone may lie on the very route the detour avoids (seed 102:
        FC-1, squeezed against a component's corner, kept stepping back toward the parked crew
        that blocked its lane instead of taking the free lane beside it, for 3,000 s).
        """
        i, j = self._cell(x, y)
        if not math.isfinite(field[j, i]):  # pushed into a blocked cell: head for a free one
            for r in range(1, 6):
                best = None
                for dj in range(-r, r + 1):
                    for di in range(-r, r + 1):
                        ii, jj = i + di, j + dj
                        if 0 <= ii < self.nx and 0 <= jj < self.ny and \
                                math.isfinite(field[jj, ii]):
                            d = di * di + dj * dj
                            key = (field[jj, ii], d) if lowest else (d, 0.0)
                            if best is None or key < best[0]:
                                best = (key, ii, jj)
                if best:
                    return self.cx[0, best[1]], self.cy[best[2], 0]
            return None
        for _ in range(LOOKAHEAD_CELLS):
            best_v, best_ij = field[j, i], None
            for di, dj in NEIGHBOURS:
                ii, jj = i + di, j + dj
                if 0 <= ii < self.nx and 0 <= jj < self.ny and field[jj, ii] < best_v:
                    best_v, best_ij = field[jj, ii], (ii, jj)
            if best_ij is None:
                break
            i, j = best_ij
        return self.cx[0, i], self.cy[j, 0]

    def _replan_around_crews(self, crew, target: int) -> None:
        """A personal field that treats the other crews' discs as (costly) obstacles."""
        mask = np.zeros((self.ny, self.nx), dtype=bool)
        r_self = crew.spec.radius_m
        for other in self.site.crews:
            if other is crew or other.status == CrewStatus.LEFT:
                continue
            ox, oy, _ = self.engine.pose(other.index)
            mask |= np.hypot(self.cx - ox, self.cy - oy) < other.spec.radius_m + r_self + 0.2
        field = self._field(crew, target, extra_blocked=mask)
        if field is not None:
            self.detour[crew.index] = (field, DETOUR_STEPS)

    # -- the escalation ladder (module doc) ---------------------------------------------------

    def _escalate(self, crew, target: int, own: np.ndarray, x: float, y: float):
        """Watch the crew's progress toward ``target`` and climb the ladder when there is
        none; returns the point to walk to while a rung steers, else None (the crew follows
        its own field and rung 1, as before the ladder)."""
        now = self.site.time_s
        esc = self.escape[crew.index]
        if esc is None or esc.target != target:
            esc = self.escape[crew.index] = _Escape(target, self._value(own, x, y), now, own)
        if now - esc.last_s > 1.5 or self._reached(crew, target, x, y):
            # Not stuck: asked for no action for a while (the floor jumped idle time, which it
            # does only while no crew walks), or where it reaches its target (waiting there
            # to start).
            esc.since_s, esc.rung = now, 0
        esc.last_s = now
        if esc.retreat is not None:
            point = self._retreating(crew, esc, x, y, now)
            if point is not None:
                return point
        followed = esc.way if esc.way is not None else own
        here = self._value(followed, x, y)
        if here == 0.0 and target < len(self.site.components):
            # in the approach band: what is left is closing in on the task area
            here = _distance_to_rect(self.site.tasks[crew.scope[target]].area, x, y)
        if followed is not esc.seen:  # a new field (areas changed, a detour): measured afresh
            esc.seen, esc.best = followed, here
        if here < esc.best - LADDER_PROGRESS_M:
            esc.best, esc.since_s, esc.rung = here, now, 0
        stuck_s = now - esc.since_s
        if esc.rung == 0 and stuck_s >= BACK_OFF_AFTER_S:
            self._back_off(crew, esc, own, x, y, now)
        elif esc.rung == 1 and stuck_s >= DETOUR_AFTER_S:
            self._detour_round_stuck_spots(crew, esc, target)
        elif esc.rung == 2 and stuck_s >= GIVE_UP_AFTER_S:
            self._give_up_this_way(crew, esc, x, y, now)
        if esc.retreat is not None:
            return self._carrot(esc.retreat[0], x, y, lowest=True)
        if esc.way is not None and self._value(esc.way, x, y) > 0.0:  # inf: in a blocked cell
            return self._carrot(esc.way, x, y, lowest=True)
        return None

    def _retreating(self, crew, esc: _Escape, x: float, y: float, now: float):
        """The point to walk to while a back-off lasts; None once it is over (at its cell or
        out of time). Why a fresh start after giving up: the old way's best and stuck places
        described a way that failed; the crew now stands somewhere else."""
        retreat, until_s, fresh = esc.retreat
        if now < until_s and self._value(retreat, x, y) > 0.0:
            return self._carrot(retreat, x, y, lowest=True)
        esc.retreat = None
        if fresh:
            esc.way, esc.spots, esc.seen, esc.since_s, esc.rung = None, [], None, now, 0
        return None

    def _back_off(self, crew, esc: _Escape, own: np.ndarray, x: float, y: float,
                  now: float) -> None:
        """Rung 2: step a few metres away from the crews round it, back the way it came.
        Why: two crews nose to nose, or one pressed into a corner, each re-plan sends
        straight back into the jam; room to turn is what a crew on site makes first. It
        remembers where it was stuck."""
        esc.spots.append((x, y))
        esc.rung = 1
        self._ask_aside(crew, esc.target, x, y, now)
        cells = self._retreat_cells(crew, x, y, *BACK_OFF_M)
        if cells.size:
            rows_cols = np.unravel_index(cells, (self.ny, self.nx))
            room = np.minimum(self._distance_to_crews(crew)[rows_cols], BACK_OFF_M[1])
            # the most room from the crews, then the farthest back up its own field
            goal = cells[np.lexsort((own[rows_cols], room))[-1]]
            esc.retreat = (self._field_to(crew, goal), now + BACK_OFF_S, False)
            self.rungs["back_off"] += 1

    def _detour_round_stuck_spots(self, crew, esc: _Escape, target: int) -> None:
        """Rung 3: a way that avoids where the crew got stuck and the crews standing still.
        Why: rung 1 avoids crews only for ``DETOUR_STEPS`` steps, and then the crew's own
        field leads back to the blocked lane (a crew that oscillates for an hour); this
        detour is kept until it reaches or gets stuck on it too."""
        esc.spots.append(self.engine.pose(crew.index)[:2])
        esc.rung = 2
        r = crew.spec.radius_m
        avoid = np.zeros((self.ny, self.nx), dtype=bool)
        for sx, sy in esc.spots:
            avoid |= np.hypot(self.cx - sx, self.cy - sy) < r + STUCK_SPOT_M
        avoid |= self._standing_crews(crew)
        x, y = esc.spots[-1]
        self._ask_aside(crew, target, x, y, self.site.time_s)
        way = self._field(crew, target, extra_blocked=avoid)
        if way is not None:
            esc.way, esc.seen = way, None
            self.rungs["detour"] += 1

    def _give_up_this_way(self, crew, esc: _Escape, x: float, y: float, now: float) -> None:
        """Rung 4: walk to a free cell some metres off, drawn from the crew's index and the
        time (no random generator: the same floor gives the same schedule), then plan afresh.
        Why: whatever wedged the crew (a knot of crews, a corner the grid thinks passable)
        is left behind, and a walk from elsewhere meets it from another side or later."""
        esc.rung = 3
        cells = self._retreat_cells(crew, x, y, *LONG_BACK_OFF_M)
        if cells.size == 0:
            esc.way, esc.spots, esc.seen, esc.since_s, esc.rung = None, [], None, now, 0
            return
        goal = cells[(crew.index * 7919 + int(now)) % cells.size]
        esc.retreat = (self._field_to(crew, goal), now + LONG_BACK_OFF_S, True)
        self.rungs["give_up"] += 1

    def _ask_aside(self, crew, target: int, x: float, y: float, now: float) -> None:
        """Ask the parked crews next to a stuck one to step aside, each to a free cell a few
        metres off, as far as it finds from the stuck crew and its target. Why: a crew
        parked with nothing to do stands still for good (it may wait for the very task the
        stuck crew is walking to: a deadlock on the imported L-shaped storey), and no way
        round it may exist. ``Engine.make_way`` lets it move for ``MAKE_WAY_S`` s."""
        tx, ty = self.site.target_xy[target]
        for other in self.site.crews:
            if other is crew or not _parked(other) or \
                    self.aside.get(other.index, (None, -math.inf))[1] > now:  # already asked
                continue
            ox, oy, _ = self.engine.pose(other.index)
            if math.hypot(ox - x, oy - y) - other.spec.radius_m - crew.spec.radius_m > \
                    MAKE_WAY_GAP_M:
                continue
            cells = self._retreat_cells(other, ox, oy, *MAKE_WAY_M)
            if cells.size == 0:
                continue
            cx, cy = self.cx.ravel()[cells], self.cy.ravel()[cells]
            room = np.minimum(np.hypot(cx - x, cy - y), np.hypot(cx - tx, cy - ty))
            goal = cells[np.argmax(room)]
            until_s = now + MAKE_WAY_S
            self.aside[other.index] = (self._field_to(other, goal), until_s)
            self.engine.make_way(other.index, until_s)
            self.rungs["make_way"] += 1

    def _reached(self, crew, target: int, x: float, y: float) -> bool:
        """Whether the crew stands where it reaches ``target`` (``decide.reached_target``'s
        regions: a task area, a storage, the outlet's circle)."""
        site = self.site
        n_comp = len(site.components)
        if target < n_comp:
            return inside(x, y, site.tasks[crew.scope[target]].area)
        if target < site.outlet_target:
            return inside(x, y, site.storages[target - n_comp].rect)
        plane = self.engine.case.plane
        return math.hypot(x - plane.outlet_x_m, y - plane.outlet_y_m) <= plane.outlet_radius_m

    def _retreat_cells(self, crew, x: float, y: float, near_m: float, far_m: float):
        """Flat indices of free cells between ``near_m`` and ``far_m`` from the crew that it
        can walk to (on its grid, round the other crews)."""
        grid = self.crew_grid[crew.index]
        d = np.hypot(self.cx - x, self.cy - y)
        ok = ~grid.blocked & (d >= near_m) & (d <= far_m) & ~self._crew_discs(crew, 0.2)
        start = self._nearest_free(grid, x, y)
        reach = dijkstra(grid.graph(self._cost(), self.area_key), directed=False,
                         indices=start, limit=3 * far_m).reshape(self.ny, self.nx)
        return np.flatnonzero((ok & np.isfinite(reach)).ravel())

    def _nearest_free(self, grid: _Grid, x: float, y: float) -> int:
        """The flat index of the free cell nearest (x, y): the crew's own, unless it is
        pressed into a blocked one."""
        i, j = self._cell(x, y)
        if not grid.blocked[j, i]:
            return j * self.nx + i
        d = np.where(grid.blocked, np.inf, np.hypot(self.cx - x, self.cy - y))
        return int(np.argmin(d))

    def _field_to(self, crew, cell: int) -> np.ndarray:
        """Cost-to-go to one cell, round the other crews."""
        grid = self.crew_grid[crew.index]
        cost = self._cost()
        cost[self._crew_discs(crew, 0.2)] = OBSTACLE_COST
        field = dijkstra(grid.graph(cost), directed=False, indices=cell)
        return field.reshape(self.ny, self.nx)

    def _crew_discs(self, crew, margin_m: float, standing_only: bool = False) -> np.ndarray:
        """Cells where the crew would touch another crew (``standing_only``: one standing
        still), with ``margin_m`` to spare."""
        mask = np.zeros((self.ny, self.nx), dtype=bool)
        for other in self.site.crews:
            if other is crew or other.status == CrewStatus.LEFT:
                continue
            if standing_only and other.moving and best_target(other) >= 0:
                continue
            ox, oy, _ = self.engine.pose(other.index)
            mask |= np.hypot(self.cx - ox, self.cy - oy) < \
                other.spec.radius_m + crew.spec.radius_m + margin_m
        return mask

    def _standing_crews(self, crew) -> np.ndarray:
        """Cells blocked by crews that stand still (working, waiting, fetching, parked or
        without a target): they will not make way, unlike a crew walking somewhere."""
        return self._crew_discs(crew, 0.2, standing_only=True)

    def _distance_to_crews(self, crew) -> np.ndarray:
        """Each cell's distance (m) to the nearest other crew's edge (inf with none)."""
        d = np.full((self.ny, self.nx), np.inf)
        for other in self.site.crews:
            if other is crew or other.status == CrewStatus.LEFT:
                continue
            ox, oy, _ = self.engine.pose(other.index)
            d = np.minimum(d, np.hypot(self.cx - ox, self.cy - oy) - other.spec.radius_m)
        return d

    def way(self, i: int) -> list[tuple[float, float]]:
        """See ``Navigator.way``."""
        crew = self.site.crews[i]
        target = best_target(crew) if crew.moving else -1
        if target < 0:
            return []
        esc = self.escape[i]
        field = esc.retreat[0] if esc is not None and esc.retreat is not None else \
            esc.way if esc is not None and esc.way is not None else self._field(crew, target)
        if field is None:
            return []
        x, y, _ = self.engine.pose(i)
        ci, cj = self._cell(x, y)
        out = [(float(x), float(y))]
        for _ in range(WAY_CELLS):
            best = None
            for di, dj in NEIGHBOURS:
                ii, jj = ci + di, cj + dj
                if 0 <= ii < self.nx and 0 <= jj < self.ny and \
                        field[jj, ii] < (field[cj, ci] if best is None else best[0]):
                    best = (field[jj, ii], ii, jj)
            if best is None:
                break
            _, ci, cj = best
            out.append((float(self.cx[0, ci]), float(self.cy[cj, 0])))
        return out

    def _idle(self, crew, pose, x, y):
        """No target: stand aside, out of active task areas and storages (and, asked to
        make way for a stuck crew, walk to the cell it was given)."""
        site = self.site
        aside = self.aside.get(crew.index)
        if aside is not None:
            field, until_s = aside
            if site.time_s < until_s:
                if self._value(field, x, y) <= 0.0:
                    return STAND_STILL
                carrot = self._carrot(field, x, y, lowest=True)
                return STAND_STILL if carrot is None else self._drive(crew, pose, x, y, *carrot)
            del self.aside[crew.index]
        if not site.in_congestion_area(x, y):  # the same test as the env's parking
            return STAND_STILL
        key = ("clear", self.crew_grid[crew.index].radius)
        field = self.fields.get(key)
        if field is None:
            grid = self.crew_grid[crew.index]
            busy = np.zeros((self.ny, self.nx), dtype=bool)
            for t in site.active_areas:
                busy |= self._rect_mask(site.tasks[t].area)
            for s in site.storages:
                busy |= self._rect_mask(s.rect)
            goals = np.flatnonzero((~busy & ~grid.blocked).ravel())
            graph = grid.graph(self._cost(), self.area_key)
            field = dijkstra(graph, directed=False, indices=goals, min_only=True)
            field = field.reshape(self.ny, self.nx)
            self.fields[key] = field
        carrot = self._carrot(field, x, y)
        if carrot is None:  # walled in by areas and components: wait for them to change
            return STAND_STILL
        return self._drive(crew, pose, x, y, *carrot)

    def _drive(self, crew, pose, x, y, px, py):
        """Turn toward (px, py), walk when facing it; swerve right from a crew ahead."""
        heading = math.atan2(py - y, px - x)
        dist = math.hypot(px - x, py - y)
        forward_cap = 3
        for other in self.site.crews:
            if other is crew or other.status == CrewStatus.LEFT:
                continue
            ox, oy, _ = self.engine.pose(other.index)
            gap = math.hypot(ox - x, oy - y) - crew.spec.radius_m - other.spec.radius_m
            if gap > 1.5:
                continue
            bearing = _wrap(math.atan2(oy - y, ox - x) - heading)
            if abs(bearing) < math.radians(50):
                # keep right: swerve to the right of a crew ahead, or left if it is on the right
                heading += math.radians(-50 if bearing >= 0 else 50)
                forward_cap = 1 if gap < 0.5 else 2
        error = _wrap(heading - pose[2])
        if abs(error) < math.radians(15):
            turn = 1
        else:
            turn = 2 if error > 0 else 0
        if abs(error) < math.radians(25):
            forward = 3
        elif abs(error) < math.radians(50):
            forward = 2
        elif abs(error) < math.radians(80):
            forward = 1
        else:
            forward = 0
        if dist < 0.3 and crew.scope_kind != ScopeKind.NONE:
            forward = min(forward, 1)
        forward = min(forward, forward_cap)
        lateral = 1
        if forward > 0 and abs(error) > math.radians(5):
            lateral = 2 if error > 0 else 0
        return (forward, lateral, turn)


def _parked(crew) -> bool:
    """A crew standing with nothing to do (reaching, no target): it will not move by itself."""
    return crew.status == CrewStatus.REACHING and crew.moving and best_target(crew) < 0


def _distance_to_rect(rect, x: float, y: float) -> float:
    """From (x, y) to the rectangle (x0, y0, x1, y1), or an outline's polygon; 0 inside."""
    if isinstance(rect, Outline):
        return float(rect.distance(x, y))
    x0, y0, x1, y1 = rect
    return math.hypot(max(x0 - x, 0.0, x - x1), max(y0 - y, 0.0, y - y1))


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))

