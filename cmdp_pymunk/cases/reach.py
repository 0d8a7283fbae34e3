"""Reachability before simulation: can every crew type reach each work point and storage it
needs, from where its crews start? Checked on the scripted navigator's own grid, with the
crews' radii (``PlaneGrid``, which the navigator plans on), so that a floor that cannot be
built is refused when it is loaded, not found an hour into a run by the stall guard.

The grid: cells of ``CELL_M``; for a crew of radius r a cell is blocked where its centre lies
closer than r + ``CLEARANCE_M`` to a component or to the plane's walls (the clearance is
negative, so that every lane a crew fits through keeps a row of free cells at this resolution;
the contact solver keeps the crew off the component). Free cells connect to their 8
neighbours, diagonals only past two free cells (no corner cutting). Components are the only
static obstacles: task areas and storages slow a crew (Eq. 1) but never close a lane, so a
floor reachable when it is loaded stays reachable.

A task's work point is reached in the band ``APPROACH_BAND_M`` around its task area (the
component grown by Table 2's area distance), a storage inside its rectangle, the outlet
within its radius.
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


def unreachable(case: Case) -> list[str]:
    """Every work point, storage or outlet that a crew type needs and cannot reach from where
    its crews start, as problems naming the task or storage, the crew type and the fix."""
    grid = PlaneGrid.of(case.plane.half_extents)
    components = [rect_of(c.x_m, c.y_m, c.width_m, c.height_m) for c in case.components]
    comp_by_id = {c.id: k for k, c in enumerate(case.components)}
    plane = case.plane
    outlet = np.hypot(grid.cx - plane.outlet_x_m, grid.cy - plane.outlet_y_m) \
        <= plane.outlet_radius_m - 0.1
    problems = []
    for crew_type, spec in case.crew_types.items():
        crews = [c for c in case.crews if c.type == crew_type]
        if not crews:
            continue
        radius = spec.radius_m
        free = ~grid.blocked(components, radius + CLEARANCE_M)
        labels = regions(grid, free)
        starts = {labels[j, i] for c in crews for i, j in [grid.cell(c.start_x_m, c.start_y_m)]}
        stuck = [c.id for c in crews
                 if labels[grid.cell(c.start_x_m, c.start_y_m)[::-1]] < 0]
        for crew in stuck:
            problems.append(f"crews: {crew} starts where a {crew_type} crew ({radius:.2f} m "
                            "radius) does not fit (against a component or a wall); fix: move "
                            "its start_x_m / start_y_m into open floor")
        starts.discard(-1)
        width = 2 * (radius + CLEARANCE_M)

        for task in case.tasks:
            tt = case.task_types[task.type]
            if tt.crew_type != crew_type:
                continue
            area = expand(components[comp_by_id[task.component]], tt.area_distance_m)
            if not reached(labels, starts, grid.rect_mask(area, -APPROACH_BAND_M)):
                problems.append(
                    f"tasks: {task.id} ({task.type} on {task.component}): no {crew_type} crew "
                    f"can reach its work point from where the {crew_type} crews start: every "
                    f"way there is narrower than {width:.2f} m (the crew's {2 * radius:.2f} m "
                    "less the navigator's clearance); fix: widen a joint or lane next to "
                    f"{task.component}, or leave it out")
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
