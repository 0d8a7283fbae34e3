"""Reachability before simulation: can every crew type reach each work point and storage it
needs, from where its crews start? Checked on the scripted navigator's own grid, with the
crews' radii (``PlaneGrid``, which the navigator plans on), so that a floor that cannot be
built is refused when it is loaded, not found an hour into a run by the stall guard.

The grid: cells of ``CELL_M``; for a crew of radius r a cell is blocked where its centre lies
closer than r + ``CLEARANCE_M`` to a component or to the plane's walls (the clearance is
negative, so that every lane a crew fits through keeps a row of free cells at this resolution;
the contact solver keeps the crew off the component). Free cells connect to their 8
neighbours, diagonals only past two free cells (no corner cutting). Components are the only
static obstacles: task areas and storages slow a crew (Eq. 1) but never close a lane.

A deck component (``Component.deck``, a slab of a wide-slab or hollow-core floor) is an
obstacle until it is laid and open floor afterwards (``laying_tasks`` says which task lays
it). So the check is a fixed point: starting with nothing laid, it takes every task whose
predecessors are taken and whose work point a crew of its type reaches from its start over
open floor and the decks laid so far, lays the decks their laying tasks lay, and goes round
again until nothing more is taken; a task never taken is reported. Open floor only grows, so
a floor that passes is built in any order the simulation takes (some remaining task is
always released and reachable). Storages and the outlet must be reached with nothing laid.
Floors without decks are checked as before: each work point from the starts.

A task's work point is reached in the band ``APPROACH_BAND_M`` around its task area (the
component grown by Table 2's area distance), a storage inside its rectangle, the outlet
within its radius. ``Reach`` keeps the regions per crew radius and laid decks, shared by the
check and the decision table (which offers a crew only the tasks it reaches now).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from .model import Case

CELL_M = 0.5  # the navigator's grid
CLEARANCE_M = -0.2  # added to a crew's radius: see the module doc
APPROACH_BAND_M = 0.6  # a component target is planned to within this of its task area
NEIGHBOURS = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1))
Rect = tuple[float, float, float, float]  # x0, y0, x1, y1 (m, the plane's centre at 0)


def rect_of(x: float, y: float, w: float, h: float) -> Rect:
    """The rectangle of centre (x, y), width w and height h."""
    return (x - w / 2, y - h / 2, x + w / 2, y + h / 2)


def expand(rect: Rect, by: float) -> Rect:
    """``rect`` grown by ``by`` on every side (a task area: Table 2's area distance)."""
    return (rect[0] - by, rect[1] - by, rect[2] + by, rect[3] + by)


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
        """Cells a crew whose radius plus clearance is ``clearance`` cannot stand on: near a
        wall or a component."""
        cx, cy = self.cx, self.cy
        out = (np.abs(cx) > self.half_w - clearance - 0.1) | \
            (np.abs(cy) > self.half_h - clearance - 0.1)
        for x0, y0, x1, y1 in components:
            dx = np.maximum(np.maximum(x0 - cx, 0.0), cx - x1)
            dy = np.maximum(np.maximum(y0 - cy, 0.0), cy - y1)
            out |= dx * dx + dy * dy < clearance * clearance
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
        """Cells whose centres lie in ``rect`` shrunk by ``shrink`` (negative: grown)."""
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
        self.rects = [rect_of(c.x_m, c.y_m, c.width_m, c.height_m) for c in case.components]
        comp_by_id = {c.id: k for k, c in enumerate(case.components)}
        self.task_rects = [expand(self.rects[comp_by_id[t.component]],
                                  case.task_types[t.type].area_distance_m) for t in case.tasks]
        self._labels: dict = {}
        self._answers: dict = {}

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
        """``regions`` of the free cells for a crew of ``radius`` with ``laid`` laid."""
        key = (round(radius, 3), laid)
        out = self._labels.get(key)
        if out is None:
            if len(self._labels) >= self.MAX_KEPT:
                self._labels, self._answers = {}, {}
            free = ~self.grid.blocked(self.open_rects(laid), radius + CLEARANCE_M)
            out = self._labels[key] = regions(self.grid, free)
        return out

    def work_point(self, task: int) -> np.ndarray:
        """The cells where task ``task``'s work point is reached (its area's approach band)."""
        return self.grid.rect_mask(self.task_rects[task], -APPROACH_BAND_M)

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
            out = self._answers[key] = bool(here >= 0 and reached(labels, {here},
                                                                  self.work_point(task)))
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


def unreachable(case: Case) -> list[str]:
    """Every work point, storage or outlet that a crew type needs and cannot reach from where
    its crews start, as problems naming the task or storage, the crew type and the fix. On a
    floor with decks a task is reached over open floor and the decks laid before it (the
    module doc's fixed point); of the tasks never taken, those reported are the ones no deck
    that can be laid opens (the others wait on them)."""
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
        width = 2 * (radius + CLEARANCE_M)
        # on a deck floor: from the starts over every deck the fixed point lays
        final = reach.labels(radius, laid)
        final_starts = {final[j, i] for c in crews
                        for i, j in [grid.cell(c.start_x_m, c.start_y_m)]} - {-1}

        for k, task in enumerate(case.tasks):
            tt = case.task_types[task.type]
            if tt.crew_type != crew_type:
                continue
            if not decks:
                if not reached(labels, starts, reach.work_point(k)):
                    problems.append(
                        f"tasks: {task.id} ({task.type} on {task.component}): no {crew_type} "
                        f"crew can reach its work point from where the {crew_type} crews "
                        f"start: every way there is narrower than {width:.2f} m (the crew's "
                        f"{2 * radius:.2f} m less the navigator's clearance); fix: widen a "
                        f"joint or lane next to {task.component}, or leave it out")
            elif k not in taken and not reached(final, final_starts, reach.work_point(k)):
                problems.append(
                    f"tasks: {task.id} ({task.type} on {task.component}): no {crew_type} crew "
                    f"can reach its work point from where the {crew_type} crews start, over "
                    f"open floor and the decks laid before it ({len(laid)} of {len(decks)} "
                    f"decks can be laid): every way there is narrower than {width:.2f} m (the "
                    f"crew's {2 * radius:.2f} m less the navigator's clearance); fix: add an "
                    f"access lane to {task.component} or widen a joint next to it, make the "
                    "components around it decks (deck = true: walked on once laid), or leave "
                    "it out")
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
