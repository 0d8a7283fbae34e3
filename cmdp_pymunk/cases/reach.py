"""Reachability before simulation: can every crew type reach each work point and storage it
needs, from where its crews start? One reach rule, shared by the case check, the scripted
navigator and the decision table, so that a floor that loads is built and a floor that is
refused could not be (issue 41):

- **Reached** is the decision table's test (``in_area``, which ``decide.reached_target``
  calls): a task's work point is reached when the crew's centre lies in the task area (the
  component grown by Table 2's area distance), a storage inside its rectangle, the outlet
  within its radius.
- **Fits** is the physics': a crew of radius r presses into a component by no more than the
  contact solver's slop, so its centre gets as close as r - ``SQUEEZE_M`` (``fit_distance``).
- **Connected** is the navigator's grid (``free_cells``, which ``agents.navigator`` plans on
  and the check proves on, for the same radius): cells of ``CELL_M``, free where the cell's
  centre keeps r + ``CLEARANCE_M`` off components and the plane's walls
  (``centre_clearance``; the clearance is negative: the contact solver keeps the crew off the
  component, and crews slide along it), connected to their 8 neighbours (diagonals only past
  two free cells: no corner cutting). A lane the crew passes can hold no such cell centre (a
  2 m lane leaves the FC, 2.02 m across, a strip of 0.38 m between two rows of 0.5 m cells,
  and the check refused such floors that ran to the end): the cells holding a point where the
  crew fits (tested on ``SUB_CELLS`` x ``SUB_CELLS`` points) are opened where they join
  regions the centres leave apart (bridges), and nowhere else, so a floor whose free cells
  are connected plans exactly as before (the golden schedules).

So a task is reached when a point where its crew fits lies inside its task area, in a cell
of the start's region or beside one (the navigator plans to the band ``APPROACH_BAND_M``
round the area, then closes in on the component). The band alone is not enough: a 0.4 m
beam along a slab's edge leaves 0.8 m of the slab's JC area beyond it, where no JCC
(1.13 m radius) gets its centre, and such a floor stalled. Components are the only static
obstacles: task areas and storages slow a crew (Eq. 1) but never close a lane.

A deck component (``Component.deck``, a slab of a wide-slab or hollow-core floor) is an
obstacle until it is laid and open floor afterwards (``laying_tasks`` says which task lays
it). So the check is a fixed point: starting with nothing laid, it takes every task whose
predecessors are taken and whose work point a crew of its type reaches from its start over
open floor and the decks laid so far, lays the decks their laying tasks lay, and goes round
again until nothing more is taken; a task never taken is reported. Open floor only grows, so
a floor that passes is built in any order the simulation takes (some remaining task is
always released and reachable). Storages and the outlet must be reached with nothing laid.
Floors without decks are checked as before: each work point from the starts.

``Reach`` keeps the regions per crew radius and laid decks, shared by the check and the
decision table (which offers a crew only the tasks it reaches now).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import binary_dilation, label
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from ..geometry import Outline, contains, grown
from .model import Case

CELL_M = 0.5  # the navigator's grid
CLEARANCE_M = -0.2  # added to a crew's radius where it fits: see the module doc
SUB_CELLS = 5  # points per cell side where a crew may fit off the cell's centre (0.1 m apart)
SQUEEZE_M = 0.1  # pymunk's collision slop (Space.collision_slop): a crew presses this far in
APPROACH_BAND_M = 0.6  # the navigator plans to within this of a task area, then closes in
NEIGHBOURS = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1))
WALL_MARGIN_M = 0.1  # a crew's centre keeps this much more off the plane's walls
Rect = tuple[float, float, float, float]  # x0, y0, x1, y1 (m, the plane's centre at 0)
# (a polygon component is a ``geometry.Outline``: a Rect, its box, carrying the polygon; every
# test below that must be exact asks the polygon, and a rectangle takes the path it took
# before polygons)


def rect_of(x: float, y: float, w: float, h: float) -> Rect:
    """The rectangle of centre (x, y), width w and height h."""
    return (x - w / 2, y - h / 2, x + w / 2, y + h / 2)


def expand(rect: Rect, by: float) -> Rect:
    """``rect`` grown by ``by`` on every side (a task area: Table 2's area distance)."""
    return (rect[0] - by, rect[1] - by, rect[2] + by, rect[3] + by)


def in_area(x, y, rect: Rect):
    """Whether the point (x, y) lies in ``rect`` (edges included), or in the polygon of an
    ``Outline``: where a crew whose centre stands there has reached a task area or a storage.
    The one test of the reach rule: ``decide.reached_target`` asks it of a crew's position
    (floats), the case check of the points where a crew fits (arrays)."""
    if type(rect) is Outline:
        return contains(rect, x, y)
    return (rect[0] <= x) & (x <= rect[2]) & (rect[1] <= y) & (y <= rect[3])


def centre_clearance(radius: float, clearance: float = CLEARANCE_M) -> float:
    """How far (m) the navigator's grid keeps a free cell's centre off components and walls
    for a crew of ``radius``: its radius plus the navigator's ``clearance``
    (``CLEARANCE_M``)."""
    return round(radius, 3) + clearance


def fit_distance(radius: float) -> float:
    """How close (m) a crew's centre gets to a component: its radius less ``SQUEEZE_M``, the
    contact solver's slop (a 2.02 m FC passes a 2.0 m lane, not a 1.8 m one)."""
    return round(radius, 3) - SQUEEZE_M


def too_close(px, py, components: list[Rect], fit: float, half_w: float,
              half_h: float) -> np.ndarray:
    """Points (arrays ``px``, ``py``) where a crew's centre stands closer than ``fit`` to a
    component or (``fit`` + ``WALL_MARGIN_M``) to the plane's walls."""
    out = (np.abs(px) > half_w - fit - WALL_MARGIN_M) | \
        (np.abs(py) > half_h - fit - WALL_MARGIN_M)
    for shape in components:
        if type(shape) is Outline:
            out |= shape.distance(px, py) < fit
            continue
        x0, y0, x1, y1 = shape
        dx = np.maximum(np.maximum(x0 - px, 0.0), px - x1)
        dy = np.maximum(np.maximum(y0 - py, 0.0), py - y1)
        out |= dx * dx + dy * dy < fit * fit
    return out


@dataclass(frozen=True)
class PlaneGrid:
    """The plane as a grid of cells (``cell_m``), centres in ``cx``, ``cy`` (ny x nx)."""

    half_w: float
    half_h: float
    cell_m: float
    nx: int
    ny: int
    cx: np.ndarray
    cy: np.ndarray

    @classmethod
    def of(cls, half_extents: tuple[float, float], cell_m: float = CELL_M) -> PlaneGrid:
        half_w, half_h = half_extents
        nx = int(math.ceil(2 * half_w / cell_m))
        ny = int(math.ceil(2 * half_h / cell_m))
        xs = -half_w + (np.arange(nx) + 0.5) * cell_m
        ys = -half_h + (np.arange(ny) + 0.5) * cell_m
        cx, cy = np.meshgrid(xs, ys)
        return cls(half_w, half_h, cell_m, nx, ny, cx, cy)

    def blocked(self, components: list[Rect], clearance: float) -> np.ndarray:
        """Cells whose centre lies closer than ``clearance`` (a crew's ``centre_clearance``)
        to a component or a wall."""
        return too_close(self.cx, self.cy, components, clearance, self.half_w, self.half_h)

    def sub_points(self, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The ``SUB_CELLS`` x ``SUB_CELLS`` points spread over each of ``cells`` (a mask):
        arrays (number of cells, SUB_CELLS ** 2) of x and y."""
        off = (np.arange(SUB_CELLS) - (SUB_CELLS - 1) / 2) * (self.cell_m / SUB_CELLS)
        ox, oy = np.meshgrid(off, off)
        return self.cx[cells][:, None] + ox.ravel(), self.cy[cells][:, None] + oy.ravel()

    def fits_somewhere(self, components: list[Rect], clearance: float,
                       cells: np.ndarray) -> np.ndarray:
        """Of ``cells`` (a mask), those holding a point (``sub_points``) where the crew
        fits."""
        px, py = self.sub_points(cells)
        out = np.zeros_like(cells)
        out[cells] = (~too_close(px, py, components, clearance, self.half_w,
                                 self.half_h)).any(axis=1)
        return out

    def edges(self, free: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(from, to, length in m) of every move between free cells (flat indices), 8
        neighbours, no corner cutting past a blocked cell."""
        nx, ny = self.nx, self.ny
        idx = np.arange(nx * ny).reshape(ny, nx)
        flat = free.ravel()
        src, dst, length = [], [], []
        for dx_, dy_ in NEIGHBOURS:
            a = idx[max(0, -dy_):ny - max(0, dy_), max(0, -dx_):nx - max(0, dx_)]
            b = idx[max(0, dy_):ny - max(0, -dy_) or None, max(0, dx_):nx - max(0, -dx_) or None]
            ok = flat[a.ravel()] & flat[b.ravel()]
            if dx_ and dy_:
                ok &= flat[(a + dx_).ravel()] & flat[(a + dy_ * nx).ravel()]
            src.append(a.ravel()[ok])
            dst.append(b.ravel()[ok])
            length.append(np.full(ok.sum(), math.hypot(dx_, dy_) * self.cell_m))
        return np.concatenate(src), np.concatenate(dst), np.concatenate(length)

    def rect_mask(self, rect: Rect, shrink: float = 0.0) -> np.ndarray:
        """Cells whose centres lie in ``rect`` shrunk by ``shrink`` (negative: grown). An
        ``Outline``'s cells are those inside its polygon and at least ``shrink`` off its
        edges, or (``shrink`` <= 0) no more than ``-shrink`` off the polygon (its corners
        grow round: a point that far from the polygon, as a crew sees it)."""
        if type(rect) is Outline:
            inside = contains(rect, self.cx, self.cy)
            if shrink > 0:
                return inside & (np.sqrt(rect.edge_distance_sq(self.cx, self.cy)) >= shrink)
            return inside | (rect.distance(self.cx, self.cy) <= -shrink)
        x0, y0, x1, y1 = rect
        return (self.cx >= x0 + shrink) & (self.cx <= x1 - shrink) & \
            (self.cy >= y0 + shrink) & (self.cy <= y1 - shrink)

    def cell(self, x: float, y: float) -> tuple[int, int]:
        """The (column, row) of the cell holding the point (x, y), clamped to the plane."""
        i = min(self.nx - 1, max(0, int((x + self.half_w) / self.cell_m)))
        j = min(self.ny - 1, max(0, int((y + self.half_h) / self.cell_m)))
        return i, j


def regions(grid: PlaneGrid, free: np.ndarray) -> np.ndarray:
    """A label per cell (ny x nx): cells with the same label reach each other; blocked
    cells get -1."""
    src, dst, _ = grid.edges(free)
    n = grid.nx * grid.ny
    _, labels = connected_components(csr_matrix((np.ones(len(src)), (src, dst)), shape=(n, n)),
                                     directed=False)
    labels = labels.reshape(grid.ny, grid.nx)
    return np.where(free, labels, -1)


def free_cells(grid: PlaneGrid, components: list[Rect], radius: float,
               clearance: float = CLEARANCE_M) -> np.ndarray:
    """The cells a crew of ``radius`` walks on (ny x nx): where its centre keeps
    ``centre_clearance`` off components and walls at the cell's centre, and the bridges of the
    module doc (cells holding a point where it fits, ``fit_distance``, opened where they join
    regions the centres leave apart). The navigator plans on these cells and the case check
    proves on them."""
    blocked = grid.blocked(components, centre_clearance(radius, clearance))
    free = ~blocked
    labels = regions(grid, free)
    if labels.max() < 1:  # one region (or none): nothing to join
        return free
    # only a cell within half a diagonal of where the crew fits can hold such a point
    fit = fit_distance(radius)
    near = blocked & ~too_close(grid.cx, grid.cy, components, fit - grid.cell_m / math.sqrt(2),
                                grid.half_w, grid.half_h)
    loose = grid.fits_somewhere(components, fit, near) if near.any() else near
    pieces, n = label(loose, structure=np.ones((3, 3), dtype=bool))
    if n == 0:
        return free
    joins: set[tuple[int, int]] = set()  # (piece, region) side by side
    for di, dj in NEIGHBOURS:
        a = pieces[max(0, -dj):grid.ny - max(0, dj), max(0, -di):grid.nx - max(0, di)]
        b = labels[max(0, dj):grid.ny - max(0, -dj) or None,
                   max(0, di):grid.nx - max(0, -di) or None]
        ok = (a > 0) & (b >= 0)
        joins.update(zip(a[ok].tolist(), b[ok].tolist(), strict=True))
    regions_of = np.zeros(n + 1, dtype=int)
    for piece, _ in joins:
        regions_of[piece] += 1
    return free | (regions_of[pieces] >= 2)


def area_points(grid: PlaneGrid, area: Rect, components: list[Rect],
                radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where a crew of ``radius`` reaches ``area`` (a task area, a ``Rect`` or an
    ``Outline``) among ``components``: the cells reaching into the area (a mask, ny x nx),
    their ``sub_points`` (arrays: number of such cells, ``SUB_CELLS ** 2``; x and y) and which
    of those points lie in the area (``in_area``, the decision table's test) where the crew
    fits (``too_close`` at ``fit_distance``). The case check's work points
    (``Reach.fits_in_area``) and the event floor's walk ends (``eventfloor.walks``) are
    these points."""
    cells = grid.rect_mask(area, -grid.cell_m)  # every cell reaching into the area
    if not cells.any():
        empty = np.zeros((0, SUB_CELLS ** 2))
        return cells, empty, empty, empty.astype(bool)
    px, py = grid.sub_points(cells)
    fit = fit_distance(radius)
    # only the components within reach of these points can be too close to them
    x0, y0, x1, y1 = expand(area, grid.cell_m + fit)
    near = [r for r in components if r[0] < x1 and x0 < r[2] and r[1] < y1 and y0 < r[3]]
    ok = in_area(px, py, area) & ~too_close(px, py, near, fit, grid.half_w, grid.half_h)
    return cells, px, py, ok


def beside(cells: np.ndarray) -> np.ndarray:
    """``cells`` (a mask) and their 8 neighbours: the cells from which a crew reaches a work
    point held by one of ``cells`` (the navigator closes in on the component from the band
    round the area)."""
    return binary_dilation(cells, structure=np.ones((3, 3), dtype=bool))


def reached(labels: np.ndarray, starts: set, mask: np.ndarray) -> bool:
    """Whether a cell of ``mask`` lies in a region of ``starts`` (blocked cells: -1)."""
    return bool(np.isin(labels[mask], list(starts)).any())


def laying_tasks(case: Case) -> dict[str, str]:
    """Task id -> the deck component it lays: per deck (``Component.deck``), its first task
    (in the case's order, the chain's order in built and imported cases) whose task type
    needs the crane (the hoisting and installation, HI: the slab is in place when it ends),
    else its last task. A deck without tasks is never laid (an obstacle throughout)."""
    decks = {c.id for c in case.components if c.deck}
    tasks: dict[str, list] = {}
    for t in case.tasks:
        if t.component in decks:
            tasks.setdefault(t.component, []).append(t)
    out = {}
    for cid, own in tasks.items():
        crane = [t for t in own if case.task_types[t.type].needs_crane]
        out[(crane[0] if crane else own[-1]).id] = cid
    return out


class Reach:
    """Who reaches what on one case's plane, over open floor and the decks laid so far: free
    cells and their regions per (crew radius, laid decks), work points per task. Cached (the
    answers depend on the case alone): shared by a floor, its clones and later episodes
    (``Reach.of``); a copy of a floor shares it (``__deepcopy__``)."""

    MAX_KEPT = 4096  # regions kept before the cache starts over (many seeds of a deck floor)

    def __init__(self, case: Case):
        self.case = case
        self.grid = PlaneGrid.of(case.plane.half_extents)
        self.rects = [c.shape for c in case.components]  # rectangles or outlines
        comp_by_id = {c.id: k for k, c in enumerate(case.components)}
        self.task_rects = [grown(self.rects[comp_by_id[t.component]],
                                 case.task_types[t.type].area_distance_m) for t in case.tasks]
        self._labels: dict = {}
        self._answers: dict = {}
        self._work: dict = {}

    def __deepcopy__(self, memo):
        return self

    _SHARED: dict[int, tuple[Case, Reach]] = {}

    @classmethod
    def of(cls, case: Case) -> Reach:
        """The case's shared ``Reach`` (by identity; the case is kept so its id stays its
        own), made on first use."""
        held = cls._SHARED.get(id(case))
        if held is None or held[0] is not case:
            if len(cls._SHARED) >= 16:
                cls._SHARED.clear()
            held = cls._SHARED[id(case)] = (case, cls(case))
        return held[1]

    def open_rects(self, laid: frozenset) -> list[Rect]:
        """The obstacles when the decks ``laid`` (component indices) are laid."""
        return [r for k, r in enumerate(self.rects) if k not in laid]

    def labels(self, radius: float, laid: frozenset = frozenset()) -> np.ndarray:
        """``regions`` of the ``free_cells`` for a crew of ``radius`` with ``laid`` laid."""
        key = (round(radius, 3), laid)
        out = self._labels.get(key)
        if out is None:
            if len(self._labels) >= self.MAX_KEPT:
                self._labels, self._answers, self._work = {}, {}, {}
            out = self._labels[key] = regions(
                self.grid, free_cells(self.grid, self.open_rects(laid), radius))
        return out

    def fits_in_area(self, radius: float, task: int,
                     laid: frozenset = frozenset()) -> np.ndarray:
        """The cells holding a point inside task ``task``'s area (``in_area``, the decision
        table's test) where a crew of ``radius`` fits with ``laid`` laid (``too_close``)."""
        key = (round(radius, 3), task, laid)
        out = self._work.get(key)
        if out is None:
            cells, _, _, ok = area_points(self.grid, self.task_rects[task],
                                          self.open_rects(laid), radius)
            out = np.zeros_like(cells)
            out[cells] = ok.any(axis=1)
            self._work[key] = out
        return out

    def work_point(self, radius: float, task: int, laid: frozenset = frozenset()) -> np.ndarray:
        """The cells from which a crew of ``radius`` reaches task ``task``'s area: a cell
        holding a point of the area where it fits (``fits_in_area``), or beside one (the
        navigator closes in on the component from the band round the area)."""
        return beside(self.fits_in_area(radius, task, laid))

    def reaches(self, radius: float, start: tuple[float, float], task: int,
                laid: frozenset = frozenset()) -> bool:
        """Whether a crew of ``radius`` starting at ``start`` (x, y) reaches task ``task``'s
        work point with the decks ``laid`` laid."""
        key = (round(radius, 3), start, task, laid)
        out = self._answers.get(key)
        if out is None:
            labels = self.labels(radius, laid)
            i, j = self.grid.cell(*start)
            here = labels[j, i]
            out = self._answers[key] = bool(
                here >= 0 and reached(labels, {here}, self.work_point(radius, task, laid)))
        return out


def taken_in_order(case: Case, reach: Reach | None = None) -> tuple[list[int], frozenset]:
    """The fixed point of the module doc: the tasks (indices) that can be taken, in the order
    taken, and the decks (component indices) laid by them."""
    reach = reach or Reach.of(case)
    index = {t.id: k for k, t in enumerate(case.tasks)}
    comp_index = {c.id: k for k, c in enumerate(case.components)}
    lays = {index[t]: comp_index[c] for t, c in laying_tasks(case).items()}
    starts: dict[str, list] = {}
    for crew in case.crews:
        starts.setdefault(crew.type, []).append((crew.start_x_m, crew.start_y_m))
    order: list[int] = []
    taken: set[int] = set()
    laid: frozenset = frozenset()
    progress = True
    while progress:
        progress = False
        for k, t in enumerate(case.tasks):
            if k in taken or not all(index[p] in taken for p in t.predecessors):
                continue
            crew_type = case.task_types[t.type].crew_type
            radius = case.crew_types[crew_type].radius_m
            if any(reach.reaches(radius, s, k, laid) for s in starts.get(crew_type, ())):
                taken.add(k)
                order.append(k)
                if k in lays:
                    laid = laid | {lays[k]}
                progress = True
    return order, laid


# the check's answers by the case's data (its JSON's digest): a case is loaded again and again
# (tests, workers, variants), and the check is most of a load (about 0.1 s on the built-in
# floor against 0.3 ms for the digest)
_CHECKED: dict[str, list[str]] = {}


def unreachable(case: Case) -> list[str]:
    """Every work point, storage or outlet that a crew type needs and cannot reach from where
    its crews start, as problems naming the task or storage, the crew type and the fix. On a
    floor with decks a task is reached over open floor and the decks laid before it (the
    module doc's fixed point); of the tasks never taken, those reported are the ones no deck
    that can be laid opens (the others wait on them)."""
    key = hashlib.sha256(case.model_dump_json().encode()).hexdigest()
    if key not in _CHECKED:
        if len(_CHECKED) >= 256:  # a sweep of many floors in one process
            _CHECKED.clear()
        _CHECKED[key] = _unreachable(case)
    return list(_CHECKED[key])


def _unreachable(case: Case) -> list[str]:
    reach = Reach.of(case)
    grid = reach.grid
    decks = [c.id for c in case.components if c.deck]
    taken, laid = taken_in_order(case, reach) if decks else ([], frozenset())
    taken = set(taken)
    plane = case.plane
    outlet = np.hypot(grid.cx - plane.outlet_x_m, grid.cy - plane.outlet_y_m) \
        <= plane.outlet_radius_m - 0.1
    problems = []
    for crew_type, spec in case.crew_types.items():
        crews = [c for c in case.crews if c.type == crew_type]
        if not crews:
            continue
        radius = spec.radius_m
        labels = reach.labels(radius)
        starts = {labels[j, i] for c in crews for i, j in [grid.cell(c.start_x_m, c.start_y_m)]}
        stuck = [c.id for c in crews
                 if labels[grid.cell(c.start_x_m, c.start_y_m)[::-1]] < 0]
        for crew in stuck:
            problems.append(f"crews: {crew} starts where a {crew_type} crew ({radius:.2f} m "
                            "radius) does not fit (against a component or a wall); fix: move "
                            "its start_x_m / start_y_m into open floor")
        starts.discard(-1)
        fit = fit_distance(radius)
        width = 2 * centre_clearance(radius)  # no way narrower opens on the navigator's grid
        # on a deck floor: from the starts over every deck the fixed point lays
        final = reach.labels(radius, laid)
        final_starts = {final[j, i] for c in crews
                        for i, j in [grid.cell(c.start_x_m, c.start_y_m)]} - {-1}

        for k, task in enumerate(case.tasks):
            tt = case.task_types[task.type]
            if tt.crew_type != crew_type:
                continue
            if not decks:
                if reached(labels, starts, reach.work_point(radius, k)):
                    continue
            elif k in taken or reached(final, final_starts, reach.work_point(radius, k, laid)):
                continue
            head = f"tasks: {task.id} ({task.type} on {task.component}): "
            if not decks and not reach.fits_in_area(radius, k).any():
                problems.append(head + _no_room(case, reach, k, crew_type, radius, fit, laid))
            elif not decks:
                problems.append(
                    head + f"no {crew_type} crew can reach its work point from where the "
                    f"{crew_type} crews start: every way there is narrower than {width:.2f} m "
                    f"(the crew's {2 * radius:.2f} m less the navigator's clearance; between two "
                    f"components it passes {2 * fit:.2f} m); fix: "
                    f"widen a joint or lane next to {task.component}, or leave it out")
            else:
                problems.append(
                    head + f"no {crew_type} crew can reach its work point from where the "
                    f"{crew_type} crews start, over open floor and the decks laid before it "
                    f"({len(laid)} of {len(decks)} decks can be laid): every way there is "
                    f"narrower than {width:.2f} m (the crew's {2 * radius:.2f} m less the "
                    f"navigator's clearance; between two components it passes {2 * fit:.2f} "
                    f"m); fix: add an access lane to {task.component} or "
                    "widen a joint next to it, make the components around it decks (deck = "
                    "true: walked on once laid), or leave it out")
        materials = {case.task_types[t].material for t in case.task_types
                     if case.task_types[t].crew_type == crew_type}
        for storage in case.storages:
            rect = rect_of(storage.x_m, storage.y_m, storage.width_m, storage.height_m)
            if storage.material in materials and not reached(labels, starts,
                                                             grid.rect_mask(rect, 0.1)):
                problems.append(f"storages: {storage.id} ({storage.material}) cannot be reached "
                                f"by the {crew_type} crews, who fetch from it; fix: move it "
                                "into open floor beside the components")
        if not reached(labels, starts, outlet):
            problems.append(f"plane: the outlet cannot be reached by the {crew_type} crews; "
                            "fix: move outlet_x_m / outlet_y_m into open floor")
    return problems


def _no_room(case: Case, reach: Reach, k: int, crew_type: str, radius: float, fit: float,
             laid: frozenset) -> str:
    """Why no crew of ``crew_type`` gets its centre into task ``k``'s area anywhere, wherever
    it comes from, and the fix: the components that fill the area's fringe."""
    task = case.tasks[k]
    area = reach.task_rects[k]
    own = next(i for i, c in enumerate(case.components) if c.id == task.component)
    others = [case.components[i].id for i, r in enumerate(reach.rects)
              if i != own and i not in laid
              and r[0] < area[2] and area[0] < r[2] and r[1] < area[3] and area[1] < r[3]]
    distance = case.task_types[task.type].area_distance_m
    inside = f" ({', '.join(others)} inside it)" if others else ""
    return (f"no {crew_type} crew can stand in its task area ({task.component} grown by "
            f"{distance:g} m){inside}: a {crew_type} crew's centre keeps {fit:.2f} m off "
            f"components (its {radius:.2f} m radius less the contact solver's {SQUEEZE_M:g} m of "
            "slop), "
            "so the decision table never sees it reach the task; fix: move "
            f"{' / '.join(others) if others else task.component} clear of {task.component}'s "
            f"edge (leave {fit:.2f} m of the task area free beside it), or leave the task out")
