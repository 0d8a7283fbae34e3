"""Plan geometry shared by every layer: rectangles, and the polygons of components that are not.

A component is an axis-aligned rectangle unless its case entry gives an ``outline`` (a simple
polygon in plane coordinates, metres). Its shape on the plane is then an :class:`Outline`: a
tuple ``(x0, y0, x1, y1)``, its bounding box, so that everything that only needs a box (the
navigator's distances, the overlap prefilters, Eq. 4's features) reads it as a rectangle,
carrying the polygon for everything that must be exact (the reach rule, a task area's
invasion and congestion, the pymunk shapes, the navigator's grid, the renderer, the 4D
export). A rectangle stays a plain tuple and takes exactly the code paths it took before
polygons (the golden schedules).

A polygon component's task area is the polygon grown by Table 2's area distance
(:func:`grown`): shapely's ``buffer`` with mitred joins, so every edge moves out by exactly
the distance and a convex corner stays a corner (a rectangle grows to the rectangle
``expand`` gives, to the last bit: tests/test_geometry.py); a corner sharper than shapely's
mitre limit (5: an angle under about 23 degrees) is bevelled.

``contains`` and ``distance`` are numpy (vectorised over the grid's points; a float pair
answers a float question), so the core imports no plotting library.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from shapely.geometry import Polygon

# shapely is imported where a polygon is made, not here: a floor of rectangles (every shipped
# case) never loads it, and the core imports no optional-looking library at module level
# (tests/test_ifc_optional.py)

Rect = tuple[float, float, float, float]  # x0, y0, x1, y1 (m, the plane's centre at 0)
Point = tuple[float, float]

MITRE_LIMIT = 5.0  # shapely's default: corners sharper than ~23 degrees are bevelled
EDGE_M = 1e-9  # a point this close to an outline's edge lies on it (edges are included)


class Outline(tuple):
    """A simple polygon on the plane, as its bounding box ``(x0, y0, x1, y1)`` (a ``Rect``
    to everything that only needs a box) carrying its corners ``points`` (counter-clockwise,
    not closed). Made by :func:`outline`."""

    points: tuple[Point, ...]

    def __new__(cls, points) -> Outline:
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        box = (float(pts[:, 0].min()), float(pts[:, 1].min()),
               float(pts[:, 0].max()), float(pts[:, 1].max()))
        self = super().__new__(cls, box)
        self.points = tuple((float(x), float(y)) for x, y in pts)
        # edges a -> b as arrays, for the vectorised tests
        self._ax, self._ay = pts[:, 0], pts[:, 1]
        self._bx, self._by = np.roll(pts[:, 0], -1), np.roll(pts[:, 1], -1)
        return self

    def __reduce__(self):  # pickle and deepcopy rebuild from the corners, not the box
        return (Outline, (self.points,))

    def __eq__(self, other) -> bool:
        return isinstance(other, Outline) and self.points == other.points

    def __ne__(self, other) -> bool:
        return not self == other

    def __hash__(self) -> int:
        return hash(self.points)

    def __repr__(self) -> str:
        return f"Outline({list(self.points)!r})"

    @property
    def polygon(self) -> Polygon:
        """The shapely polygon (made on each call; for the importer, the check, the export)."""
        from shapely.geometry import Polygon

        return Polygon(self.points)

    @property
    def area_m2(self) -> float:
        return float(self.polygon.area)

    def edge_distance_sq(self, x, y) -> np.ndarray:
        """Squared distance from each point to the nearest edge (shape of ``x``)."""
        x = np.asarray(x, dtype=np.float64)[..., None]
        y = np.asarray(y, dtype=np.float64)[..., None]
        ex, ey = self._bx - self._ax, self._by - self._ay
        t = ((x - self._ax) * ex + (y - self._ay) * ey) / (ex * ex + ey * ey)
        t = np.clip(t, 0.0, 1.0)
        dx, dy = x - (self._ax + t * ex), y - (self._ay + t * ey)
        return (dx * dx + dy * dy).min(axis=-1)

    def _crossing(self, x, y) -> np.ndarray:
        """The even-odd rule: a ray from each point towards +x crosses the outline an odd
        number of times when the point is inside (the boundary is ``edge_distance_sq``'s)."""
        x = np.asarray(x, dtype=np.float64)[..., None]
        y = np.asarray(y, dtype=np.float64)[..., None]
        ay, by = self._ay, self._by
        straddles = (ay > y) != (by > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            at_x = self._ax + (y - ay) * (self._bx - self._ax) / (by - ay)
        return (straddles & (x < at_x)).sum(axis=-1) % 2 == 1

    def contains(self, x, y):
        """Whether each point lies in the polygon, edges included (as a rectangle's test)."""
        out = self._crossing(x, y) | (self.edge_distance_sq(x, y) <= EDGE_M * EDGE_M)
        return bool(out) if out.ndim == 0 else out

    def nearest(self, x: float, y: float) -> Point:
        """The polygon's point nearest to (x, y): the point itself inside, else the nearest
        point of its nearest edge (where a crew closes in on the component)."""
        if self._crossing(x, y):
            return x, y
        ex, ey = self._bx - self._ax, self._by - self._ay
        t = np.clip(((x - self._ax) * ex + (y - self._ay) * ey) / (ex * ex + ey * ey), 0.0, 1.0)
        qx, qy = self._ax + t * ex, self._ay + t * ey
        k = int(np.argmin((qx - x) ** 2 + (qy - y) ** 2))
        return float(qx[k]), float(qy[k])

    def distance(self, x, y) -> np.ndarray:
        """Distance (m) from each point to the polygon: 0 inside, else to its nearest edge."""
        d = np.sqrt(self.edge_distance_sq(x, y))
        return np.where(self._crossing(x, y), 0.0, d)


def outline(points) -> Outline:
    """The :class:`Outline` of a simple polygon given by its corners (either winding, closed
    or not): counter-clockwise, without a repeated closing corner."""
    from shapely.geometry import Polygon
    from shapely.geometry.polygon import orient

    pts = [tuple(map(float, p)) for p in points]
    if len(pts) > 1 and pts[0] == pts[-1]:
        pts = pts[:-1]
    ring = orient(Polygon(pts), sign=1.0).exterior.coords[:-1]
    return Outline(ring)


def outline_problems(points) -> list[str]:
    """Why ``points`` is not a simple polygon (empty: it is): fewer than 3 corners, a
    repeated corner, no area, or edges that cross. Each problem names the fix."""
    import shapely

    pts = [tuple(p) for p in points]
    if len(pts) > 1 and pts[0] == pts[-1]:
        pts = pts[:-1]
    if len(pts) < 3:
        return [f"outline has {len(pts)} corners; fix: give at least 3 [x, y] corners of a "
                "simple polygon"]
    if len(set(pts)) < len(pts):
        return ["outline repeats a corner; fix: give each corner once (the outline closes "
                "itself)"]
    xy = np.asarray(pts, dtype=np.float64)
    if np.linalg.matrix_rank(xy - xy[0], tol=1e-9) < 2:
        return ["outline has no area (its corners lie on one line); fix: give the corners of "
                "the component's footprint"]
    if not shapely.LinearRing(pts).is_simple:
        return ["outline's edges cross each other; fix: list the corners in order round the "
                "polygon"]
    return []


def rect_corners(rect: Rect) -> list[Point]:
    """A rectangle's corners, counter-clockwise from (x0, y0)."""
    x0, y0, x1, y1 = rect
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def corners(shape: Rect) -> list[Point]:
    """The corners of a rectangle or an outline, counter-clockwise."""
    return list(shape.points) if isinstance(shape, Outline) else rect_corners(shape)


def grown(shape: Rect, by: float) -> Rect:
    """A task area: ``shape`` grown by ``by`` (m) on every side (Table 2's area distance). A
    rectangle grows to a rectangle (``cases.reach.expand``, unchanged); an outline by shapely's
    mitred buffer (the module doc)."""
    if not isinstance(shape, Outline):
        return (shape[0] - by, shape[1] - by, shape[2] + by, shape[3] + by)
    if by == 0:
        return shape
    poly = shape.polygon.buffer(by, join_style="mitre", mitre_limit=MITRE_LIMIT)
    return outline(poly.exterior.coords)


def contains(shape: Rect, x, y):
    """Whether the point(s) (x, y) lie in a rectangle or an outline, edges included. A
    rectangle is its box's test, an outline its box's and then its polygon's."""
    box = (shape[0] <= x) & (x <= shape[2]) & (shape[1] <= y) & (y <= shape[3])
    if not isinstance(shape, Outline):
        return box
    if np.ndim(box) == 0:
        return bool(box) and shape.contains(x, y)
    out = np.array(box, dtype=bool)
    if out.any():
        out[out] = shape.contains(np.asarray(x)[out], np.asarray(y)[out])
    return out


def overlap(a: Rect, b: Rect, tolerance_m: float = 0.0) -> bool:
    """Whether two shapes' interiors meet: rectangles by their boxes (strictly, as before
    polygons), outlines by the area their polygons share (more than ``tolerance_m`` wide:
    the one shrunk by it still meets the other's interior)."""
    box = a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]
    if not box or not (isinstance(a, Outline) or isinstance(b, Outline)):
        return box
    pa, pb = as_polygon(a), as_polygon(b)
    if tolerance_m > 0:
        pa = pa.buffer(-tolerance_m, join_style="mitre")
    return bool(pa.intersection(pb).area > 0.0)


def as_polygon(shape: Rect) -> Polygon:
    """A shapely polygon of a rectangle or an outline."""
    from shapely.geometry import Polygon

    return Polygon(corners(shape))


def convex_parts(shape: Rect) -> list[list[Point]]:
    """Convex pieces whose union is the shape, for pymunk's ``Poly`` (convex only): a
    rectangle or a convex outline is one piece; a concave outline is cut by shapely's
    constrained Delaunay triangulation, and the triangles are merged back greedily while
    the union stays convex (an L is two or three pieces, not a fan of slivers)."""
    import shapely
    from shapely.geometry import Polygon
    from shapely.geometry.polygon import orient

    pts = corners(shape)
    poly = Polygon(pts)
    if not isinstance(shape, Outline) or poly.convex_hull.area - poly.area <= 1e-12:
        return [pts]
    tris = [Polygon(t.exterior.coords[:-1])
            for t in shapely.constrained_delaunay_triangles(poly).geoms]
    pieces: list[Polygon] = []
    for tri in tris:
        for k, piece in enumerate(pieces):
            union = piece.union(tri)
            if union.geom_type == "Polygon" and union.convex_hull.area - union.area <= 1e-9:
                pieces[k] = union.simplify(0.0)
                break
        else:
            pieces.append(tri)
    return [list(orient(p, sign=1.0).exterior.coords[:-1]) for p in pieces]
