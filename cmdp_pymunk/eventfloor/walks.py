"""Walks on the event floor: the navigator's shortest path and its time under Eq. 1.

A crew walks from where it stands to its target's reach region (the task area, the storage,
the outlet) along the shortest path on the plane's grid (``cases.reach.PlaneGrid``, the one
the scripted navigator plans on and the case check proves reachable; cells a crew of its
radius cannot stand on are blocked). The path ends only where the case check counts the
target reached (one reach rule, issue 41): at a free cell holding, or beside, a point of the
task area where the crew fits (``reach.area_points``, ``reach.beside``: the check's work
point), and stops at the area's point nearest that cell, a hair inside, where the crew fits
and the step there passes no component, else at the nearest of the check's points beside
the cell (``area_ends``); at a free cell of the storage or the outlet, as the check asks. The
path is the shortest to where it stops. A target the check calls unreachable from where the
crew stands has no such path: the crew does not walk and never arrives (a stall, as on the
pymunk floor, where it presses against what stands in the way). The walk's time is the sum
over the path's steps of length / velocity, each step at the crew's Eq. 1 maximum in that cell
(``move.congested_velocity``: slowed by the carried load's deceleration and by the most
congested task or storage area holding the cell, never below v_min), times the crew type's
calibrated ``walk_factor`` (swerving around crews, detours), plus its ``dock_s`` once per
arrival (turning toward the target and docking at it: ``calibration``).

Paths to one goal from every cell are one Dijkstra (``scipy``; from a task area's goal node,
joined to each goal cell by its last step), kept per crew radius and goal for the life of the
planner: a floor and its clones and later episodes of the same case share them
(``WalkPlanner.__deepcopy__``). On a floor with decks (``Component.deck``)
a laid deck is open floor: the free cells, fields and paths are kept per set of laid decks
(``Site.laid``; the latest ``MAX_DECK_LAYERS`` sets of them), one set on a floor without.
"""

from __future__ import annotations

import bisect
import functools
import math
from dataclasses import dataclass, field
from itertools import accumulate, islice
from operator import truediv

import numpy as np
from scipy.ndimage import distance_transform_edt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from ..cases.reach import (
    CELL_M,
    PlaneGrid,
    area_points,
    beside,
    fit_distance,
    free_cells,
    in_area,
    too_close,
)
from ..geometry import Outline, contains
from ..state import CrewState, Rect, Site, inside


def congestion_areas(site: Site) -> list[tuple[Rect, float]]:
    """The areas that slow a walk now (Eq. 1), each with its I_area: the active task areas,
    then the stocked storages."""
    areas = [(site.tasks[t].area, site.tasks[t].congestion_index) for t in site.active_areas]
    areas += [(st.rect, site.storage_congestion(st)) for st in site.storages if st.stock > 0.0]
    return areas


def congestion_along(site: Site, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """I_area (Eq. 1) at many points at once: the most congested (lowest) index of the active
    task areas and stocked storages holding each point, 1 outside them
    (``move.congestion_index`` for one point; a test holds the two equal)."""
    areas = congestion_areas(site)
    if not areas:
        return np.ones(len(xs))
    r = np.asarray([rect for rect, _ in areas])
    x, y = xs[:, None], ys[:, None]
    inside = (x >= r[:, 0]) & (x <= r[:, 2]) & (y >= r[:, 1]) & (y <= r[:, 3])
    for k, (area, _) in enumerate(areas):
        if type(area) is Outline:  # a polygon's box holds more than the polygon
            inside[:, k] = contains(area, xs, ys)
    return np.where(inside, np.asarray([index for _, index in areas]), 1.0).min(
        axis=1, initial=1.0)


def walking_velocities(crew: CrewState, congestion, lateral_m_s: float) -> list[float]:
    """The crew's forward maximum (m/s) under Eq. 1 at each congestion index:
    max(c * I_area * v_f, v_min), v_min the lower of v_f and the lateral velocity
    (``move.velocity_limits``). On plain floats: a walk has a few dozen points, where
    numpy's per-call cost is most of the work."""
    v_f = crew.spec.velocity_m_s
    c = crew.spec.carry_deceleration if crew.load > 0.0 else 1.0
    v_min = min(v_f, lateral_m_s)
    return [max(c * index * v_f, v_min) for index in congestion]


@dataclass(eq=False)
class Walk:
    """One walk: where it goes, the points it passes and when (seconds from its start, the
    calibrated walk factor applied), and when it arrives (a simulated second).

    The points, times and metres are plain lists of floats: every event looks up where each
    walker is and how far it walked, and on lists a lookup costs a bisection, not numpy's
    per-call overhead (the same numbers)."""

    target: int
    task: int  # the task index behind a component target, or -1
    start_s: float
    xs: list[float]
    ys: list[float]
    times: list[float]  # cumulative seconds at each point, ``times[-1]`` the whole walk
    arrival_s: float
    distances: list[float]  # cumulative metres at each point
    # the last distance asked (time, metres): each event asks again for the one the last
    # event asked for
    _last_distance: tuple = field(init=False, repr=False, default=(math.nan, 0.0))

    def at(self, time_s: float) -> tuple[float, float]:
        """Where the crew is at ``time_s`` (on the path's points; at the start before it,
        at the end after it)."""
        xs = self.xs
        if time_s >= self.arrival_s:
            return xs[-1], self.ys[-1]
        k = bisect.bisect_right(self.times, time_s - self.start_s) - 1
        k = min(max(k, 0), len(xs) - 1)
        return xs[k], self.ys[k]

    def distance_at(self, time_s: float) -> float:
        """Metres walked along the path by ``time_s`` (linear between its points)."""
        if self._last_distance[0] == time_s:
            return self._last_distance[1]
        metres = _interp(time_s - self.start_s, self.times, self.distances)
        self._last_distance = (time_s, metres)
        return metres

    def heading(self) -> float:
        """The heading of the walk's last step (rad)."""
        xs, ys = self.xs, self.ys
        if len(xs) < 2:
            return 0.0
        return math.atan2(ys[-1] - ys[-2], xs[-1] - xs[-2])


class _Path:
    """A kept path: its points from a free cell into the goal's reach region, the length of
    each step between them, and which of its points (but the last) each area holds; as plain
    lists of floats, what a walk is made of."""

    def __init__(self, px: np.ndarray, py: np.ndarray):
        self.px, self.py = px.tolist(), py.tolist()
        self.steps = np.hypot(np.diff(px), np.diff(py)).tolist()
        self.held: dict[Rect, list[int]] = {}  # rect -> indices into a walk's points
        # the box around its points but the last: most areas lie off a path, and are told so
        # by four comparisons
        xs, ys = self.px[:-1], self.py[:-1]
        self.box = (min(xs), min(ys), max(xs), max(ys)) if xs else \
            (math.inf, math.inf, -math.inf, -math.inf)

    def points_in(self, rect: Rect) -> list[int]:
        """The indices, among a walk's points (its start first), of this path's points but
        the last that ``rect`` holds."""
        x0, y0, x1, y1 = rect  # an outline's bounding box, too
        bx0, by0, bx1, by1 = self.box
        if x0 > bx1 or x1 < bx0 or y0 > by1 or y1 < by0:
            return []
        if type(rect) is Outline:  # a polygon: its own test on the points in its box
            px, py = np.asarray(self.px[:-1]), np.asarray(self.py[:-1])
            return [int(k) + 1 for k in np.flatnonzero(contains(rect, px, py))]
        return [k + 1 for k, (x, y) in enumerate(zip(self.px[:-1], self.py[:-1], strict=True))
                if x0 <= x <= x1 and y0 <= y <= y1]


class _Radius:
    """The free cells, their graph and each cell's nearest free cell, for one crew radius."""

    def __init__(self, plane: PlaneGrid, components: list[Rect], radius: float):
        # the navigator's cells and the case check's (one reach rule: ``reach.free_cells``)
        self.blocked = ~free_cells(plane, components, radius)
        src, dst, length = plane.edges(~self.blocked)
        n = plane.nx * plane.ny
        self.graph = csr_matrix((length, (src, dst)), shape=(n, n))
        self.edges = (src, dst, length)  # for a graph with a task area's last steps added
        # every cell's nearest free cell: where a crew pushed against a component steps to
        _, (jj, ii) = distance_transform_edt(self.blocked, return_indices=True)
        self.nearest_free = (jj * plane.nx + ii).ravel().tolist()  # looked up per walk


class _Field:
    """The ways to one goal for one crew radius: each cell's next cell toward the goal
    (``pred``: a Dijkstra's predecessors, a goal cell's -9999 or the graph's goal node
    ``sink``; None where no goal cell is free), which cells end a walk there (``goal``,
    flat), and where a walk ending at each goal cell stops (``ends``: goal cell -> (x, y); a
    task area's point where the crew fits; None: the cell's centre)."""

    def __init__(self, pred: list | None, goal: list[bool], ends: dict | None, sink: int):
        self.pred, self.goal, self.ends, self.sink = pred, goal, ends, sink

    def end(self, plane: PlaneGrid, cell: int) -> tuple[float, float]:
        """Where a walk whose path ends at ``cell`` (a goal cell) stops."""
        if self.ends is None:
            return float(plane.cx.flat[cell]), float(plane.cy.flat[cell])
        return self.ends[cell]


def area_ends(plane: PlaneGrid, area: Rect, components: list[Rect], radius: float,
              goal: np.ndarray, points: tuple) -> dict[int, tuple[float, float]]:
    """Where a walk to a task ``area`` stops, for each goal cell (flat index; ``goal`` a mask,
    ``reach.beside`` of the cells holding a point of the area where a crew of ``radius``
    fits among ``components``; ``points`` those points, ``reach.area_points``): the area's
    point nearest the cell's centre, a hair inside (``_into``: where the crew closes in on
    the component), where the crew fits and the step there passes no component; else the
    nearest of ``points`` held by the cell or one of its 8 neighbours that the crew steps to
    so (the nearest of them where none does). Goal cell -> (x, y): each end passes the
    decision table's test (``reach.in_area``) and the check's fit (``reach.too_close``)."""
    cells, px, py, ok = points
    fit = fit_distance(radius)
    # only the components within a step (1.5 cells) of the area can be in the way
    reach_m = 1.5 * plane.cell_m * math.sqrt(2) + fit
    close = [r for r in components if r[0] < area[2] + reach_m and area[0] - reach_m < r[2]
             and r[1] < area[3] + reach_m and area[1] - reach_m < r[3]]

    def fits(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return in_area(x, y, area) & ~too_close(x, y, close, fit, plane.half_w, plane.half_h)

    def clear(x0: np.ndarray, y0: np.ndarray, x1: np.ndarray, y1: np.ndarray) -> np.ndarray:
        """Whether each step from (x0, y0) to (x1, y1) stays out of every component (tested
        every 5 cm or closer)."""
        t = np.linspace(0.0, 1.0, 41)[:, None]
        x, y = x0 + t * (x1 - x0), y0 + t * (y1 - y0)
        inside = np.zeros(x.shape, dtype=bool)
        for shape in close:
            if type(shape) is Outline:
                inside |= contains(shape, x, y)
            else:
                inside |= (x > shape[0]) & (x < shape[2]) & (y > shape[1]) & (y < shape[3])
        return ~inside.any(axis=0)

    flat = np.flatnonzero(goal.ravel())
    gx, gy = plane.cx.ravel()[flat], plane.cy.ravel()[flat]
    if type(area) is Outline:
        near = np.array([_into(("rect", area), x, y)
                         for x, y in zip(gx.tolist(), gy.tolist(), strict=True)]).reshape(-1, 2)
    else:  # ``_into`` on every goal cell at once: the same clamp
        x0, y0, x1, y1 = area
        m = min(0.01, (x1 - x0) / 4, (y1 - y0) / 4)
        near = np.stack((np.minimum(np.maximum(gx, x0 + m), x1 - m),
                         np.minimum(np.maximum(gy, y0 + m), y1 - m)), axis=1)
    good = fits(near[:, 0], near[:, 1]) & clear(gx, gy, near[:, 0], near[:, 1])
    out = {int(c): (float(x), float(y))
           for c, x, y in zip(flat[good], near[good, 0], near[good, 1], strict=True)}
    row_of = np.full(plane.nx * plane.ny, -1)
    row_of[np.flatnonzero(cells.ravel())] = np.arange(int(cells.sum()))  # ``sub_points``'
    for c, x, y in zip(flat[~good].tolist(), gx[~good].tolist(), gy[~good].tolist(),
                       strict=True):
        j, i = divmod(c, plane.nx)
        rows = [row_of[jj * plane.nx + ii] for jj in (j - 1, j, j + 1)
                for ii in (i - 1, i, i + 1) if 0 <= jj < plane.ny and 0 <= ii < plane.nx]
        rows = np.asarray([k for k in rows if k >= 0])
        qx, qy = px[rows][ok[rows]], py[rows][ok[rows]]
        order = np.argsort(np.hypot(qx - x, qy - y), kind="stable")
        ways = clear(np.full(len(qx), x), np.full(len(qx), y), qx, qy)[order]
        k = order[int(np.argmax(ways))]  # the nearest with a clear step, else the nearest
        out[c] = (float(qx[k]), float(qy[k]))
    return out


class _Layer:
    """What the planner keeps for one set of laid decks (on a floor without decks, the only
    one): free cells per radius, fields per (radius, goal), paths per (radius, goal, cell)."""

    def __init__(self, components: list[Rect]):
        self.components = components
        self.radii: dict[float, _Radius] = {}
        self.fields: dict = {}  # (radius, goal) -> _Field
        self.paths: dict = {}  # (radius, goal, start cell) -> a _Path, None: no way there


_UNHINDERED = (1.0,)  # the congestion index outside every area (Eq. 1)
_UNKNOWN = object()  # a path not planned yet (None: no way there)
MAX_DECK_LAYERS = 16  # sets of laid decks kept (a deck floor meets one per deck laid)


class WalkPlanner:
    """Shortest walks on one case's plane (see the module doc)."""

    def __init__(self, site: Site):
        case = site.case
        self.plane = PlaneGrid.of(case.plane.half_extents, CELL_M)
        self.xs = self.plane.cx.ravel()
        self.ys = self.plane.cy.ravel()
        self._components = [c.rect for c in site.components]
        self._layers: dict[frozenset, _Layer] = {}
        self._goals: dict[tuple[int, int], tuple] = {}  # (target, task) -> ``_goal_of``'s
        self._last_layer: tuple = (None, None)  # (laid decks, their layer) of the last walk
        self.lateral_m_s = case.simulation.lateral_velocity_m_s
        self.outlet = (case.plane.outlet_x_m, case.plane.outlet_y_m,
                       case.plane.outlet_radius_m)

    def __deepcopy__(self, memo):
        return self  # shared: paths depend on the case alone

    def _layer(self, laid: frozenset) -> _Layer:
        """The layer of the decks ``laid`` (component indices), made on first use."""
        if laid is self._last_layer[0]:  # the same decks as the last walk's (most walks)
            return self._last_layer[1]
        layer = self._layers.get(laid)
        if layer is None:
            if len(self._layers) >= MAX_DECK_LAYERS:  # forget the oldest set of laid decks
                del self._layers[next(k for k in self._layers if k)]
            layer = self._layers[laid] = _Layer(
                [r for k, r in enumerate(self._components) if k not in laid])
        self._last_layer = (laid, layer)
        return layer

    def _radius(self, radius: float, layer: _Layer) -> _Radius:
        key = round(radius, 3)
        if key not in layer.radii:
            layer.radii[key] = _Radius(self.plane, layer.components, radius)
        return layer.radii[key]

    def _goal_mask(self, goal: tuple) -> np.ndarray:
        """The cells of a storage or the outlet where a walk there may end (before the free
        cells are taken), as the case check asks (``reach.unreachable``)."""
        if goal[0] == "outlet":
            x, y, r = self.outlet
            return np.hypot(self.plane.cx - x, self.plane.cy - y) <= r - 0.1
        return self.plane.rect_mask(goal[1], 0.1)

    def _predecessors(self, radius: float, goal: tuple, layer: _Layer) -> _Field:
        """The field toward ``goal`` for a crew of ``radius`` over ``layer`` (kept).

        A storage or the outlet: a multi-source Dijkstra from its free cells. A task area:
        the case check's work point (``Reach.work_point``: the free cells holding, or
        beside, a point of the area where the crew fits, among the components still
        standing), each joined to a goal node by its last step to the nearest such point
        (``area_ends``), so a path is shortest to where the walk stops, not to the cell."""
        key = (round(radius, 3), goal)
        if key not in layer.fields:
            grid = self._radius(radius, layer)
            n = self.plane.nx * self.plane.ny
            ends = None
            if goal[0] == "area":
                points = area_points(self.plane, goal[1], layer.components, radius)
                fits = np.zeros_like(points[0])
                fits[points[0]] = points[3].any(axis=1)
                mask = beside(fits) & ~grid.blocked
                ends = area_ends(self.plane, goal[1], layer.components, radius, mask, points)
            else:
                mask = self._goal_mask(goal) & ~grid.blocked
            mask = mask.ravel()
            goals = np.flatnonzero(mask)
            pred = None
            if goals.size and ends is None:
                _, pred, _ = dijkstra(grid.graph, directed=False, indices=goals,
                                      min_only=True, return_predecessors=True)
                pred = pred.tolist()
            elif goals.size:
                # the last steps as edges to a goal node n (a step of length 0 would be no
                # edge in a sparse graph: each gets a millimetre, the same for all)
                last = [math.hypot(ends[c][0] - self.xs[c], ends[c][1] - self.ys[c]) + 1e-3
                        for c in goals.tolist()]
                src, dst, length = grid.edges
                graph = csr_matrix((np.concatenate((length, last)),
                                    (np.concatenate((src, np.full(goals.size, n))),
                                     np.concatenate((dst, goals)))), shape=(n + 1, n + 1))
                _, pred = dijkstra(graph, directed=False, indices=n, return_predecessors=True)
                pred = pred[:n].tolist()
            layer.fields[key] = _Field(pred, mask.tolist(), ends, n)
        return layer.fields[key]

    def walk(self, site: Site, crew: CrewState, start: tuple[float, float], target: int,
             now_s: float, walk_factor: float, dock_s: float = 0.0,
             areas: list[tuple[Rect, float]] | None = None) -> Walk:
        """The crew's walk from ``start`` to ``target`` of its scope, leaving at ``now_s``
        (see the module doc); it arrives at a whole second, one at the earliest (the engine
        sees a reach at the end of a second). ``areas``: ``congestion_areas(site)`` if the
        caller has them (one event's walks share them)."""
        task = crew.scope.get(target, -1)
        path = self.path(site, crew, start, target, task)
        x, y = float(start[0]), float(start[1])
        if path is None:  # no way there (the check refuses such a floor): it never arrives
            return Walk(target, task, now_s, [x], [y], [0.0], math.inf, [0.0])
        px, py = path.px, path.py
        congestion = self._congestion(site, path, start, areas)
        # Eq. 1's velocity at each point, worked out once per congestion index (most points
        # lie outside every area, at 1); each step's length over its velocity, summed in
        # order (``accumulate`` adds left to right, as numpy's cumsum and ``+=`` in a loop
        # did: the same floats), times the walk factor; and the metres at each point
        # (``Walk.distance_at``), from the path's kept steps. ``map`` over floats' own
        # operators: the same operations as the expressions, without a frame per point
        steps = path.steps
        if congestion is None:  # no area on the way: one velocity all the way
            v = walking_velocities(crew, _UNHINDERED, self.lateral_m_s)[0]
            elapsed = math.hypot(px[0] - x, py[0] - y) / v
            seconds = map(v.__rtruediv__, steps)
        else:
            indices = list(dict.fromkeys(congestion))
            velocity = dict(zip(indices, walking_velocities(crew, indices, self.lateral_m_s),
                                strict=True))
            elapsed = math.hypot(px[0] - x, py[0] - y) / velocity[congestion[0]]
            seconds = map(truediv, steps, map(velocity.__getitem__, islice(congestion, 1, None)))
        metres = float(np.hypot(px[0] - x, py[0] - y))
        times = [0.0]
        times += map(walk_factor.__mul__, accumulate(seconds, initial=elapsed))
        distances = [0.0]
        distances += accumulate(steps, initial=metres)
        times[-1] += dock_s  # turning to the target and docking at it, once per arrival
        arrival = now_s + max(1.0, math.ceil(times[-1] - 1e-9))
        return Walk(target, task, now_s, [x, *px], [y, *py], times, arrival, distances)

    def path(self, site: Site, crew: CrewState, start: tuple[float, float], target: int,
             task: int) -> _Path | None:
        """The kept path from the free cell nearest ``start`` to ``target`` (``task`` behind
        it, or -1) for the crew's radius, over the decks laid now; None where no path leads
        there (the case check's unreachable)."""
        goal = self._goals.get((target, task))  # a target's goal is the case's: kept
        if goal is None:
            goal = self._goals[target, task] = self._goal_of(site, target, task)
        goal, region = goal
        radius = crew.spec.radius_m
        rkey = round(radius, 3)
        layer = self._layer(site.laid)
        grid = layer.radii.get(rkey)
        if grid is None:
            grid = self._radius(radius, layer)
        i, j = self.plane.cell(*start)
        key = (rkey, goal, grid.nearest_free[j * self.plane.nx + i])
        path = layer.paths.get(key, _UNKNOWN)
        if path is _UNKNOWN:
            path = layer.paths[key] = self._path(radius, goal, region, key[2], layer)
        return path

    def _congestion(self, site: Site, path: _Path, start: tuple[float, float],
                    areas: list[tuple[Rect, float]] | None = None) -> list[float] | None:
        """``congestion_along(site, xs[:-1], ys[:-1])`` of the walk ``xs`` from ``start``
        along ``path`` (a test holds the two equal), or None where every point is outside
        every area (all 1). Which of a path's points an area holds never changes, so it is
        kept per path and area: a walk looks up only the areas on the plane now
        (``areas``, else ``congestion_areas(site)``), instead of testing every point against
        every area."""
        out = None
        x, y = start
        held_by = path.held
        for rect, index in congestion_areas(site) if areas is None else areas:
            held = held_by.get(rect)
            if held is None:
                held = held_by[rect] = path.points_in(rect)
            at_start = inside(x, y, rect)
            if held or at_start:
                if out is None:
                    out = [1.0] * len(path.px)  # the start, then the path's points but the last
                for k in held:
                    if index < out[k]:
                        out[k] = index
                if at_start and index < out[0]:
                    out[0] = index
        return out

    def _path(self, radius: float, goal: tuple, region: tuple, cell: int,
              layer: _Layer) -> _Path | None:
        """The path's points from a free cell to a goal cell and on to where the walk stops
        in the reach region (``_Field.end``), and the length of each step between them; None
        where no path leads to a goal cell (kept per radius, goal and start cell)."""
        field = self._predecessors(radius, goal, layer)
        pred = field.pred
        cells = [cell]
        if pred is not None:
            while True:
                nxt = pred[cell]
                if nxt < 0 or nxt == field.sink:
                    break
                cells.append(nxt)
                cell = nxt
        if not field.goal[cell]:  # another region than the goal's, or the goal has none
            return None
        cells = np.asarray(cells)
        end = _into(region, *field.end(self.plane, cell))
        px = np.concatenate((self.xs[cells], (end[0],)))
        py = np.concatenate((self.ys[cells], (end[1],)))
        return _Path(px, py)

    def _goal_of(self, site: Site, target: int, task: int) -> tuple[tuple, tuple]:
        """(the goal's key, the reach region: ("rect", rect) or ("disc", x, y, r))."""
        n_comp = len(site.components)
        if target == site.outlet_target:
            x, y, r = self.outlet
            return ("outlet",), ("disc", x, y, r)
        if target >= n_comp:
            rect = site.storages[target - n_comp].rect
            return ("storage", rect), ("rect", rect)
        area = site.tasks[task].area if task >= 0 else site.components[target].rect
        return ("area", area), ("rect", area)


def _interp(x: float, xp: list, fp: list) -> float:
    """``numpy.interp(x, xp, fp)`` for one x on lists (xp increasing, two points or more):
    numpy's own steps (its ends, a point hit exactly, then slope times offset plus the
    start), so the same number without numpy's per-call cost."""
    if x >= xp[-1]:
        return fp[-1]
    if x < xp[0]:
        return fp[0]
    j = bisect.bisect_right(xp, x) - 1
    if xp[j] == x:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[j]


def _into(region: tuple, x: float, y: float) -> tuple[float, float]:
    """The point of the reach region nearest (x, y), a hair inside it (the engine's reach
    test is inclusive, so a point on the edge would do; the margin keeps rounding out). A
    walk's end (``_Field.end``) already lies in the region: this moves it by at most the
    margin, off an edge it lies on."""
    if region[0] == "disc":
        _, cx, cy, r = region
        d = math.hypot(x - cx, y - cy)
        if d <= r * 0.95:
            return x, y
        return cx + (x - cx) * 0.95 * r / d, cy + (y - cy) * 0.95 * r / d
    x0, y0, x1, y1 = region[1]
    m = min(0.01, (x1 - x0) / 4, (y1 - y0) / 4)
    if type(region[1]) is Outline:  # the polygon's nearest point, the margin inside it
        return _inner(region[1], m).nearest(x, y)
    return min(max(x, x0 + m), x1 - m), min(max(y, y0 + m), y1 - m)


@functools.lru_cache(maxsize=1024)
def _inner(outline: Outline, m: float) -> Outline:
    """``outline`` shrunk by the margin ``m`` (itself where it is thinner than that): kept,
    since every goal cell of a polygon's area asks it (``area_ends``)."""
    inner = outline.polygon.buffer(-m, join_style="mitre")
    if inner.geom_type != "Polygon" or inner.is_empty:  # thinner than the margin
        return outline
    return Outline(inner.exterior.coords[:-1])


__all__ = ["WalkPlanner", "Walk", "congestion_along", "congestion_areas", "walking_velocities"]
