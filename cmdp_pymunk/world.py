"""The pymunk space: walls, components, sensor areas, the outlet and the crews' bodies.

Physics only: nothing here knows about tasks or rewards, and nothing imports a renderer.
Crews are dynamic discs whose velocity is set inside their ``velocity_func`` every substep
(pymunk issue #186: assigning ``body.velocity`` before a step lets bodies sink into walls).
Task areas and storage areas are sensor shapes: they slow crews (Eq. 1, see ``move``) and
surrounding rays report them, but they never block movement.

A polygon component (``geometry.Outline``) is ``pymunk.Poly`` shapes, convex only: a concave
outline (an L, a notched slab) is its convex pieces (``geometry.convex_parts``), and so is a
task area grown from it. A rectangle is one box, as before polygons. A crew crossing the seam
between two pieces of one task area enters the second piece too: its congestion entries
(``contacts``) count that crossing once more (Eq. 6's entry penalty on polygon floors only).

``World`` is the engine's ``physics.Physics``: the engine and the stages reach it only through
that protocol's members (poses, velocities, desired velocities, steps, contacts, task areas,
crews leaving and coming back, rays, rebuilding).
"""

from __future__ import annotations

import math

import pymunk

from . import interrupt
from .cases.model import Case
from .geometry import Outline, convex_parts
from .physics import (  # noqa: F401 - the kinds, also read from here
    COMPONENT,
    CREW,
    KIND_NAMES,
    N_KINDS,
    NOTHING,
    OUTLET,
    STORAGE,
    TASK_AREA,
    WALL,
)
from .state import Rect, Site

CATEGORY = {kind: 1 << kind for kind in range(1, N_KINDS)}
ALL = pymunk.ShapeFilter.ALL_CATEGORIES()

# Frontal rays look through congestion areas to the targets beyond them; surrounding rays
# stop at every area, so they report the congestion around the crew.
FRONTAL_MASK = CATEGORY[WALL] | CATEGORY[COMPONENT] | CATEGORY[CREW] | CATEGORY[STORAGE] \
    | CATEGORY[OUTLET]
SURROUNDING_MASK = FRONTAL_MASK | CATEGORY[TASK_AREA]

try:  # pymunk's own cffi binding: rays without a Python object per answer (4x faster)
    from pymunk._chipmunk import ffi as _ffi
    from pymunk._chipmunk import lib as _lib
except ImportError:  # pragma: no cover - a pymunk without it falls back to the public API
    _ffi = _lib = None

CREW_DENSITY_KG_M2 = 80.0  # only the ratio between crews matters when they push each other
WALL_RADIUS_M = 0.1


def _box(body: pymunk.Body, rect: Rect) -> pymunk.Poly:
    x0, y0, x1, y1 = rect
    return pymunk.Poly(body, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)])


def _shapes(body: pymunk.Body, shape: Rect) -> list[pymunk.Poly]:
    """A rectangle's box, or an outline's convex pieces (pymunk's polygons are convex)."""
    if type(shape) is not Outline:
        return [_box(body, shape)]
    return [pymunk.Poly(body, part) for part in convex_parts(shape)]


def _tag(shape: pymunk.Shape, kind: int, target: int = -1, crew: int = -1) -> pymunk.Shape:
    """Attributes that rays and collision callbacks read off a shape."""
    shape.kind = kind
    shape.target = target
    shape.crew = crew
    shape.collision_type = kind
    return shape


class RayCaster:
    """``segment_query_first`` that answers (alpha, kind, target) or None.

    Through pymunk's own cffi binding when it is there: the C query is a quarter of what
    ``Space.segment_query_first`` costs, the rest being the Python objects it builds for each
    answer. Shapes are found again by their C address (cffi pointers hash by address).
    ``public=True`` forces the public API; both give the same answers (tests/test_rays.py).
    """

    def __init__(self, space: pymunk.Space, public: bool = False):
        self.space = space
        self.fast = _lib is not None and not public and hasattr(space, "_space")
        self.tags: dict = {}
        if self.fast:
            self.cast = self._fast_cast()

    def register(self, shape: pymunk.Shape) -> None:
        if self.fast:
            self.tags[shape._shape] = (shape.kind, shape.target)

    def unregister(self, shape: pymunk.Shape) -> None:
        if self.fast:
            del self.tags[shape._shape]

    def cast(self, start, end, shape_filter) -> tuple[float, int, int] | None:
        """The first hit of the segment start -> end as (alpha, kind, target), or None."""
        info = self.space.segment_query_first(start, end, 0.0, shape_filter)
        if info is None:
            return None
        return info.alpha, info.shape.kind, info.shape.target

    def _fast_cast(self):
        """``cast`` through cffi, as a closure over everything it reads (rays are the hottest
        call of a step: 28 a deciding crew). cffi converts a ``ShapeFilter`` (a namedtuple)
        to its C struct on every call, which cost as much as the query itself: the struct is
        kept per filter."""
        query, c_space = _lib.cpSpaceSegmentQueryFirst, self.space._space
        info, null, tags = _ffi.new("cpSegmentQueryInfo *"), _ffi.NULL, self.tags
        filters: dict = {}
        owners: list = []  # each struct in ``filters`` lives in its owner's memory

        def cast(start, end, shape_filter) -> tuple[float, int, int] | None:
            c_filter = filters.get(shape_filter)
            if c_filter is None:
                owner = _ffi.new("cpShapeFilter *", tuple(shape_filter))
                owners.append(owner)
                c_filter = filters[shape_filter] = owner[0]
            hit = query(c_space, start, end, 0.0, c_filter, info)
            if hit == null:
                return None
            kind, target = tags[hit]
            return info.alpha, kind, target

        return cast


class World:
    """The physical state S_phy of one episode, on pymunk (a ``physics.Physics``)."""

    def __init__(self, case: Case, site: Site, public_rays: bool = False):
        self.case, self.site, self.public_rays = case, site, public_rays
        self._carried: set = set()  # contacts that outlived a rebuild (``__setstate__``)
        self.space = pymunk.Space()
        self.space.iterations = 10
        self.rays = RayCaster(self.space, public=public_rays)
        self.at_rest = False
        self.motion_version = 0  # bumped by anything rays could see change
        # every crew's (x, y, heading) as the last physics step left them, or None: read the
        # bodies (pymunk's accessors cost a call each, and every second reads each pose
        # several times: the motion, the navigator, the observations)
        self._poses: list[tuple[float, float, float]] | None = None
        static = self.space.static_body
        half_w, half_h = case.plane.half_extents
        corners = [(-half_w, -half_h), (half_w, -half_h), (half_w, half_h), (-half_w, half_h)]
        for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
            self._add_static(_tag(pymunk.Segment(static, a, b, WALL_RADIUS_M), WALL),
                             CATEGORY[WALL])
        # by component index: its shapes (one box, or an outline's convex pieces)
        self.component_shapes: dict[int, tuple[pymunk.Shape, ...]] = {}
        for comp in site.components:
            if comp.index in site.laid:  # a deck laid (a rebuild): walked on, not an obstacle
                continue
            shapes = tuple(_tag(part, COMPONENT, target=comp.index)
                           for part in _shapes(static, comp.rect))
            for shape in shapes:
                self._add_static(shape, CATEGORY[COMPONENT])
            self.component_shapes[comp.index] = shapes
        self.storage_rects: dict[int, Rect] = {}  # by target index
        for st in site.storages:
            self._add_static(_tag(_box(static, st.rect), STORAGE, target=st.target),
                             CATEGORY[STORAGE], sensor=True)
            self.storage_rects[st.target] = st.rect
        outlet = pymunk.Circle(static, case.plane.outlet_radius_m,
                               (case.plane.outlet_x_m, case.plane.outlet_y_m))
        self._add_static(_tag(outlet, OUTLET, target=site.outlet_target), CATEGORY[OUTLET],
                         sensor=True)
        self.area_shapes: dict[int, tuple[pymunk.Shape, ...]] = {}  # by task index
        self._static_body = static

        n = len(site.crews)
        # desired world-frame (vx, vy, omega) per crew, read by the velocity functions
        self.desired = [[0.0, 0.0, 0.0] for _ in range(n)]
        self.bodies: list[pymunk.Body] = []
        self.frontal_filters, self.surrounding_filters = [], []
        for crew, spec in zip(site.crews, case.crews, strict=True):
            r = crew.spec.radius_m
            mass = CREW_DENSITY_KG_M2 * crew.spec.occupation_area_m2
            body = pymunk.Body(mass, pymunk.moment_for_circle(mass, 0, r))
            body.position = (spec.start_x_m, spec.start_y_m)
            body.angle = math.radians(spec.start_heading_deg)
            body.velocity_func = self._velocity_func(crew.index)
            shape = _tag(pymunk.Circle(body, r), CREW, crew=crew.index)
            shape.friction = 0.0  # no torque from contacts: turning is the policy's alone
            shape.elasticity = 0.0
            group = crew.index + 1  # a crew's rays never hit the crew itself
            shape.filter = pymunk.ShapeFilter(group=group, categories=CATEGORY[CREW])
            self.space.add(body, shape)
            self.rays.register(shape)
            self.bodies.append(body)
            self.frontal_filters.append(pymunk.ShapeFilter(group=group, mask=FRONTAL_MASK))
            self.surrounding_filters.append(
                pymunk.ShapeFilter(group=group, mask=SURROUNDING_MASK))

        # collision and congestion-entry counts per crew and object kind since the last read
        self.contacts = [[0] * N_KINDS for _ in range(n)]
        for kind in (WALL, COMPONENT, TASK_AREA, STORAGE):
            self.space.on_collision(CREW, kind, begin=self._count_contact)
        self.space.on_collision(CREW, CREW, begin=self._count_crew_contact)

    def _add_static(self, shape: pymunk.Shape, category: int, sensor: bool = False) -> None:
        shape.sensor = sensor
        shape.filter = pymunk.ShapeFilter(categories=category)
        self.space.add(shape)
        self.rays.register(shape)

    def _velocity_func(self, i: int):
        desired = self.desired

        def set_velocity(body, gravity, damping, dt):
            d = desired[i]
            body.velocity = (d[0], d[1])
            body.angular_velocity = d[2]

        return set_velocity

    def _count_contact(self, arbiter, space, data) -> None:
        crew_shape, other = arbiter.shapes
        if self._carried and (crew_shape, other) in self._carried:
            return  # it began before a rebuild: counted then
        self.contacts[crew_shape.crew][other.kind] += 1

    def _count_crew_contact(self, arbiter, space, data) -> None:
        a, b = arbiter.shapes
        if self._carried and frozenset((a, b)) in self._carried:
            return
        self.contacts[a.crew][CREW] += 1
        self.contacts[b.crew][CREW] += 1

    # -- changes the construction stages make -----------------------------------------------

    def add_task_area(self, task: int, rect: Rect) -> None:
        """a^c1: the task area appears on the plane as a sensor (or sensors: an outline's
        convex pieces)."""
        shapes = tuple(_tag(part, TASK_AREA) for part in _shapes(self._static_body, rect))
        for shape in shapes:
            shape.task = task
            self._add_static(shape, CATEGORY[TASK_AREA], sensor=True)
        self.area_shapes[task] = shapes
        self.motion_version += 1

    def remove_task_area(self, task: int) -> None:
        """a^c9: the task area is deregistered."""
        for shape in self.area_shapes.pop(task):
            self.rays.unregister(shape)
            self.space.remove(shape)
        self.motion_version += 1

    def lay_deck(self, component: int) -> None:
        """A deck is laid: its box leaves the space, so crews walk over it (and rays no longer
        see it: a laid deck's later tasks are found by the navigator, which reads the state)."""
        for shape in self.component_shapes.pop(component):
            self.rays.unregister(shape)
            self.space.remove(shape)
        self.motion_version += 1

    def remove_crew(self, i: int) -> None:
        """A crew that went through the outlet leaves the plane."""
        body = self.bodies[i]
        for shape in list(body.shapes):
            self.rays.unregister(shape)
        self.space.remove(body, *list(body.shapes))
        self.motion_version += 1

    def return_crew(self, i: int) -> None:
        """A crew that was away (a disruption, ``remove_crew``) comes back where it left."""
        body = self.bodies[i]
        body.velocity, body.angular_velocity = (0.0, 0.0), 0.0
        self.space.add(body, *list(body.shapes))
        for shape in body.shapes:
            self.rays.register(shape)
        self.at_rest = False
        self.motion_version += 1

    # -- physics ------------------------------------------------------------------------------

    # -- branching: a world as plain data, and rebuilt from it --------------------------------

    def __getstate__(self) -> dict:
        """The physical state as plain data (no pymunk or cffi objects): what ``copy.deepcopy``
        of an engine copies. pymunk's contact cache (its solver's warm start) is not part of
        it, so a rebuilt world may differ from one never rebuilt in the last digits of a
        contact; ``Engine.clone`` rebuilds the original too, and both go on identically."""
        bodies = [None if b.space is None else
                  (tuple(b.position), b.angle, tuple(b.velocity), b.angular_velocity)
                  for b in self.bodies]
        # a crew away for a disruption keeps its pose off the plane, to come back there
        away = {i: (tuple(b.position), b.angle) for i, b in enumerate(self.bodies)
                if b.space is None and self.site.crews[i].absent}
        return {"case": self.case, "site": self.site, "public_rays": self.public_rays,
                "bodies": bodies, "away": away, "areas": list(self.area_shapes),
                "desired": [list(d) for d in self.desired],
                "contacts": [list(c) for c in self.contacts],
                "at_rest": self.at_rest, "motion_version": self.motion_version}

    def __setstate__(self, state: dict) -> None:
        """Rebuild the space from ``__getstate__``'s data: walls, components (but the decks
        laid, which the site holds), storages, the outlet and crews as at the start, then the
        task areas on the plane in the order they appeared, the crews' poses and velocities,
        and what the counters held."""
        self.__init__(state["case"], state["site"], state["public_rays"])
        for i, pose in enumerate(state["bodies"]):
            if pose is None:
                if i in state.get("away", {}):
                    self.bodies[i].position, self.bodies[i].angle = state["away"][i]
                self.remove_crew(i)
                continue
            body = self.bodies[i]
            body.position, body.angle, body.velocity, body.angular_velocity = pose
        self._poses = None  # the poses were set above
        for task in state["areas"]:
            self.add_task_area(task, self.site.tasks[task].area)
        self.space.reindex_shapes_for_body(self._static_body)
        for body in self.bodies:
            if body.space is not None:
                self.space.reindex_shapes_for_body(body)
        self.desired[:] = [list(d) for d in state["desired"]]
        self.contacts = [list(c) for c in state["contacts"]]
        self.at_rest, self.motion_version = state["at_rest"], state["motion_version"]
        # Overlaps that exist now began before the rebuild: pymunk will call ``begin`` for
        # them again at the next step, and they must not count twice.
        carried = set()
        for body in self.bodies:
            if body.space is None:
                continue
            for crew_shape in body.shapes:
                for hit in self.space.shape_query(crew_shape):
                    other = hit.shape
                    if getattr(other, "kind", None) == CREW:
                        carried.add(frozenset((crew_shape, other)))
                    elif other is not None:
                        carried.add((crew_shape, other))
        self._carried = carried

    def step(self, dt: float, substeps: int) -> None:
        """Advance the physics, unless the plane is at rest and nobody wants to move.

        At rest means the last physics step moved no body; with every desired velocity zero,
        stepping again would move nothing either (the same rule applies in every run, so it
        never breaks determinism). ``motion_version`` counts the changes rays could see.
        """
        wants_to_move = any(d[0] or d[1] or d[2] for d in self.desired)
        if not wants_to_move and self.at_rest:
            return
        before = self._poses if self._poses is not None else self._read_poses()
        h = dt / substeps
        interrupt.enter()  # a Ctrl-C inside pymunk's callbacks is held, then raised here
        try:
            for _ in range(substeps):
                self.space.step(h)
        finally:
            interrupt.leave()
        self._carried = set()  # ``begin`` has fired for every overlap that outlived a rebuild
        self._poses = after = self._read_poses()
        self.at_rest = after == before
        if not self.at_rest:
            self.motion_version += 1

    def take_contacts(self, i: int) -> list[int]:
        """The crew's collision counts by kind since the last call, then zeroed."""
        counts = self.contacts[i]
        self.contacts[i] = [0] * N_KINDS
        return counts

    # -- what the engine reads and sets (``physics.Physics``) ---------------------------------

    def pose(self, i: int) -> tuple[float, float, float]:
        """Crew i's x, y (m) and heading (rad), read off its body (kept from the last
        physics step: nothing else moves a body)."""
        poses = self._poses
        if poses is not None:
            return poses[i]
        body = self.bodies[i]
        x, y = body.position
        return x, y, body.angle

    def set_pose(self, i: int, x: float, y: float, heading: float) -> None:
        """Put crew i at (x, y) facing ``heading`` (rad) by hand (tests, tools): the body and
        the kept poses both."""
        body = self.bodies[i]
        body.position, body.angle = (x, y), heading
        self.space.reindex_shapes_for_body(body)
        self._poses = None

    def _read_poses(self) -> list[tuple[float, float, float]]:
        out = []
        for body in self.bodies:
            x, y = body.position
            out.append((x, y, body.angle))
        return out

    def velocity(self, i: int) -> tuple[float, float]:
        """Crew i's world-frame velocity (m/s)."""
        vx, vy = self.bodies[i].velocity
        return vx, vy

    def drive(self, i: int, vx: float, vy: float, omega: float) -> None:
        """Crew i's desired velocity, applied inside its ``velocity_func`` every substep."""
        desired = self.desired[i]
        desired[0], desired[1], desired[2] = vx, vy, omega

    def ray_query(self, i: int):
        """``(cast, frontal, surrounding)`` for crew i: ``RayCaster.cast`` and the crew's two
        shape filters (its own group, so its rays never hit itself)."""
        return self.rays.cast, self.frontal_filters[i], self.surrounding_filters[i]

    def rebuild(self) -> None:
        """Rebuild the space from its own data (``__getstate__``, ``__setstate__``)."""
        self.__setstate__(self.__getstate__())
