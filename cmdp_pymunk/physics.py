"""What the engine needs of the physical plane S_phy: one small protocol, ``Physics``.

The engine (``engine.Engine``) and the stages it runs (``move``, ``decide``, ``disruptions``,
``observe``) reach the plane only through these members, so a second implementation (another
physics library, a grid, a replay of recorded poses) can replace pymunk's (``world.World``)
without touching them: ``Engine(case, ..., physics=MyWorld)``, where ``MyWorld(case, site)``
builds one episode's plane (walls, components, storages, the outlet, a body per crew at its
start pose). Crews are indices (the case's order). Nothing here imports pymunk.

Object kinds (``NOTHING`` ... ``OUTLET``) are shared by the rays' type ids (Eq. 3), the
contact counts and the reaching reward's eta keys (Eqs. 6-7).

An implementation must also survive ``copy.deepcopy`` as an independent plane (``Engine.clone``
copies the engine whole) and ``rebuild()`` itself from the same data, so that the original and
its copy go on identically.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

from .state import Rect

# Object kinds: ray type ids (observation), collision types and reward eta keys share them.
NOTHING, WALL, COMPONENT, CREW, TASK_AREA, STORAGE, OUTLET = range(7)
KIND_NAMES = ("nothing", "wall", "component", "crew", "task_area", "storage", "outlet")
N_KINDS = len(KIND_NAMES)

# A ray's first hit: (alpha along the segment in [0, 1], object kind, target index or -1).
Hit = tuple[float, int, int]


@runtime_checkable
class Physics(Protocol):
    """The physical state of one episode, as the engine drives and reads it."""

    at_rest: bool  # the last step moved no body (with no velocity asked, the next won't either)
    motion_version: int  # changes whenever anything a ray could see moved, appeared or vanished
    storage_rects: dict[int, Rect]  # storages by target index (a ray from inside one leaves it)

    def pose(self, i: int) -> tuple[float, float, float]:
        """Crew i's x, y (m, the plane's centre at 0) and heading (rad, counter-clockwise
        from +x); also of a crew off the plane (where it left)."""

    def velocity(self, i: int) -> tuple[float, float]:
        """Crew i's world-frame velocity (m/s) after the last step."""

    def drive(self, i: int, vx: float, vy: float, omega: float) -> None:
        """Crew i's desired world-frame velocity (m/s) and turning rate (rad/s), held until
        changed: P_phy's input, set from the reaching actions by Eq. 1 (``move``)."""

    def step(self, dt: float, substeps: int) -> None:
        """Advance the plane by ``dt`` seconds (``substeps`` solver steps), moving each crew at
        its desired velocity as contacts allow; sets ``at_rest``."""

    def take_contacts(self, i: int) -> list[int]:
        """Crew i's collisions and congestion entries by object kind (``N_KINDS`` counts) since
        the last call, then zeroed."""

    def add_task_area(self, task: int, rect: Rect) -> None:
        """a^c1: a task area appears (a sensor: it slows and is seen, it never blocks)."""

    def remove_task_area(self, task: int) -> None:
        """a^c9: the task area is deregistered."""

    def lay_deck(self, component: int) -> None:
        """A deck component (``cases.model.Component.deck``) is laid: from now on crews walk
        over it, it no longer blocks them."""

    def remove_crew(self, i: int) -> None:
        """Crew i leaves the plane (the outlet, a disruption); its pose is kept."""

    def return_crew(self, i: int) -> None:
        """Crew i comes back, at rest, where it left."""

    def ray_query(self, i: int) -> tuple[Callable[[Any, Any, Any], Hit | None], Any, Any]:
        """Crew i's ray caster: ``(cast, frontal, surrounding)``, where ``cast(start, end,
        mode)`` answers the first ``Hit`` of the segment (never crew i itself) or None, and the
        two modes are opaque: ``frontal`` sees through task areas to what lies beyond them,
        ``surrounding`` stops at them (section 3.6.2). Rays are the hottest call of a second:
        the caller keeps the three for all of a crew's rays."""

    def rebuild(self) -> None:
        """Rebuild from its own state, as a deep copy is built (``Engine.clone`` rebuilds the
        original so that both go on identically)."""


__all__ = ["Physics", "Hit", "NOTHING", "WALL", "COMPONENT", "CREW", "TASK_AREA", "STORAGE",
           "OUTLET", "KIND_NAMES", "N_KINDS"]
