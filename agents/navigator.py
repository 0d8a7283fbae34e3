"""The scripted navigator: drives each crew to its highest-value target with reaching actions.

It is the low level until a trained one exists, and afterwards the yardstick the trained one is
measured against. It reads the engine's state (not the rays) and answers with the same
``MultiDiscrete([4, 3, 3])`` actions the learned policy uses.

How it plans: the plane is a grid (``cell_m``); for each crew size, cells closer to a component
or wall than the crew's radius plus ``clearance_m`` are blocked. The default clearance is
negative (-0.2 m) so that every lane a crew fits through keeps at least one row of free cells at
this resolution; the contact solver keeps the crew off the component, and crews slide along
it (no friction). A cost-to-go field to the target's reach region
(the task area, the storage, the outlet) is computed with Dijkstra over the free cells, with
active task areas and stocked storages costing more to cross (they slow a crew, Eq. 1, and
entering them is penalised, Eq. 6). Fields are cached per target and re-planned whenever task
areas appear or vanish. A crew follows the field's steepest descent a few cells ahead.

How it moves: turn toward that point, walk when roughly facing it, side-step for small
offsets; swerve from crews ahead (keeping right); a crew that makes no progress for a while
re-plans around the other crews' current positions, and if that fails too, backs off sideways.
A crew without a target stands still, unless it stands in an active task area or a storage,
which it leaves.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from cmdp_pymunk.cases.reach import APPROACH_BAND_M, CELL_M, CLEARANCE_M, NEIGHBOURS, PlaneGrid
from cmdp_pymunk.move import STAND_STILL
from cmdp_pymunk.state import CrewStatus, ScopeKind

from .steering import best_target

AREA_COST = 4.0  # crossing an active task area costs this much more than open floor
STORAGE_COST = 1.5
LOOKAHEAD_CELLS = 4
STUCK_STEPS = 12  # no progress for this many steps: re-plan around the crews
STUCK_PROGRESS_M = 0.3
DETOUR_STEPS = 40


class _Grid:
    """Free cells and their 8-connected edges for one crew radius, on the plane's grid
    (``cmdp_pymunk.cases.reach.PlaneGrid``, the one the case check proves reachable), with
    the decks laid so far open floor."""

    def __init__(self, nav: _Plans, radius: float):
        self.radius = radius
        laid = nav.site.laid
        self.blocked = nav.plane.blocked(
            [c.rect for c in nav.site.components if c.index not in laid],
            radius + nav.clearance_m)
        self.src, self.dst, self.length = nav.plane.edges(~self.blocked)
        self.n = nav.nx * nav.ny
        self.graphs: dict = {}

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
            w = self.length * 0.5 * (c[self.src] + c[self.dst])
            g = csr_matrix((w, (self.src, self.dst)), shape=(self.n, self.n))
            if key is not None:
                self.graphs = {key: g}  # one area state at a time
        return g


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
            return STAND_STILL
        pose = self.engine.pose(crew.index)
        x, y = pose[0], pose[1]
        target = best_target(crew)
        if target < 0:
            return self._idle(crew, pose, x, y)
        if self.goal[crew.index] != target:
            self.goal[crew.index] = target
            self.best[crew.index] = math.inf
            self.since_progress[crew.index] = 0
            self.detour[crew.index] = None
        field = self._field(crew, target)
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
            # in the approach band: close in on the component's nearest point
            x0, y0, x1, y1 = self.site.components[target].rect
            px, py = min(max(x, x0), x1), min(max(y, y0), y1)
        else:
            carrot = self._carrot(field, x, y, lowest=detoured)
            px, py = carrot if carrot is not None else self.site.target_xy[target]
        return self._drive(crew, pose, x, y, px, py)

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

    def _idle(self, crew, pose, x, y):
        """No target: stand aside, out of active task areas and storages."""
        site = self.site
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


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))

