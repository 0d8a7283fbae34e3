"""How crews get from where they stand to their targets: the one part of the engine that varies.

The engine (``engine.Engine``) runs one loop, ``advance``: span after span, each the paper's
execution process (section 3.2): the crews move (P_phy, a ``Motion``), construction advances
for the span (P_cons, Eq. 2, ``construct``), disruptions, the decision table (Table 1,
``decide``), the target evaluation (Eq. 4 or 9), the event log and the counting
(``metrics.Counters``). A motion says how long the next span is and moves the crews through
it; everything else is written once, in the engine and its stages.

Two motions ship:

- ``PhysicsMotion`` (this module): the paper's floor. A span is one second of P_phy: the low
  level's reaching actions through Eq. 1 on a ``physics.Physics`` plane (pymunk's
  ``world.World`` by default); the ground truth.
- ``eventfloor.WalkMotion``: the event floor. A span runs to the next second at which
  anything can change; crews walk the shortest path to their best target in the time Eq. 1
  gives along it, with the calibrated walk factor and invasion.

A third motion is a class with these members (``tests/test_motion.py`` writes one that
teleports each crew to its target after its Eq. 1 time, from ``docs/architecture.md``'s
recipe): ``Engine(case, motion=MyMotion())`` or ``engine.clone(motion=MyMotion())``. A motion
instance belongs to one engine (it may hold per-episode state, e.g. the walks): ``clone``
copies it with the engine.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from . import move
from .state import CrewStatus
from .world import World

if TYPE_CHECKING:
    from .cases.model import Case
    from .engine import Engine
    from .physics import Physics
    from .state import CrewState, Site


@dataclass
class Span:
    """What one span did (``seconds`` of it), per crew: for rewards', metrics' and R_e's sake.

    ``states``: each crew's (disruption, status, idle cause) as the span is counted
    (``metrics.Counters.count``); None: as the crews stand when it is counted (the physics
    motion counts a second by the state it ends in). ``timeouts``: re-evaluation time-outs
    crossed in the span (section 3.6's clock, ``engine.tick_reach_clock``)."""

    seconds: int
    moving: list[bool]  # moving (reaching or deregistered) when the span began
    had_target: list[bool]  # moving after a target when the span began
    distance_m: list[float]  # walked in the span
    contacts: list = field(default_factory=list)  # per crew by object kind; None: none taken
    rewards: list[float] = field(default_factory=list)  # R_r, Eqs. 6-7 (motions with actions)
    terms: dict[str, float] = field(default_factory=dict)  # R_e's terms, Eq. 5, at its end
    terms_before: dict[str, float] = field(default_factory=dict)  # ... held through the span
    timeouts: list[int] = field(default_factory=list)
    states: list | None = None
    disrupted: bool = False  # a disruption was under way when the span began


Second = Span  # a span of the physics motion is one simulated second


def tick_reach_clock(crew: CrewState, seconds: int, cap: int) -> int:
    """Section 3.6's clock: ``seconds`` more without a reach for a crew after a target;
    returns the re-evaluation time-outs crossed (multiples of ``cap``, the
    ``reevaluate_after_steps``, passed)."""
    before = crew.steps_since_reach
    crew.steps_since_reach = before + seconds
    return (before + seconds) // cap - before // cap


def crew_states(site: Site) -> list[tuple]:
    """What the counters read of each crew (``Span.states``): disruption, status, idle cause."""
    return [(c.disruption, c.status, c.idle_cause) for c in site.crews]


@runtime_checkable
class Motion(Protocol):
    """P_phy for the engine: how long the next span is and how the crews move through it."""

    name: str  # what outputs record ("pymunk", "event"; ``--fidelity`` names it)
    takes_actions: bool  # reaching actions move the crews: a low level acts, R_r is paid
    # Eq. 2's n * I_agent for ``construct.advance`` (``construct.invasion``' signature); None:
    # the crews standing in the area now
    invasion_of: Callable | None

    def plane(self, case: Case, site: Site) -> Physics:
        """One episode's plane (``physics.Physics``), crews at their start poses."""

    def check(self, engine: Engine) -> None:
        """Refuse an engine this motion cannot run (a ValueError with the fix)."""

    def begin(self, engine: Engine) -> None:
        """A new episode's plane is built (``reset``), or the motion joins an episode under
        way (``clone(motion=...)``): per-episode state starts here."""

    def span_s(self, engine: Engine) -> int:
        """Whole seconds to the end of the next span (at least 1)."""

    def quiet(self, engine: Engine) -> bool:
        """Nothing moves in the coming second and no crew needs a decision: the span may skip
        P_phy and, if only c2 would fire, the decisions."""

    def move(self, engine: Engine, actions, span: Span) -> None:
        """P_phy over the span: the crews' new places (``engine.positions``, the plane) and
        ``span.distance_m``; may refine the span's counting facts."""

    def needs_action(self, engine: Engine, crew: CrewState) -> bool:
        """Whether the crew's reaching action is used in the coming span."""

    def position_due(self, engine: Engine, crew: CrewState) -> bool:
        """Whether a moving crew's position is logged now (trajectories)."""

    def end_span(self, engine: Engine, span: Span, ctx) -> None:
        """After the span's decisions, rewards and log (the reach clocks, the walks)."""

    def replan(self, engine: Engine) -> None:
        """Values may have changed (from outside, between seconds): the crews follow."""


# motions beyond the two shipped, by the name ``--fidelity`` and ``make_floor`` take
_REGISTERED: dict[str, Callable] = {}


def register_motion(name: str, factory: Callable) -> None:
    """Make a motion available by ``name`` to ``eventfloor.make_floor`` and so to every
    command's ``--fidelity`` (``cmdp-simulate``, ``cmdp-evaluate``...): ``factory(calibration)``
    returns a new ``Motion`` (one per engine; ``calibration`` is the event floor's, None
    unless ``--calibration`` was given). The shipped names cannot be taken."""
    if name in ("pymunk", "event"):
        raise ValueError(f"motion name {name!r} is taken by a shipped motion; fix: another name")
    if not name.isidentifier():
        raise ValueError(f"motion name {name!r} is not an identifier; fix: letters, digits and "
                         "underscores, e.g. 'teleport'")
    _REGISTERED[name] = factory


def registered_motions() -> dict[str, Callable]:
    """The motions registered beyond the shipped two (``register_motion``), by name."""
    return dict(_REGISTERED)


class PhysicsMotion:
    """The paper's P_phy (see the module doc): one second a span, the low level's reaching
    actions through Eq. 1 on a ``physics.Physics`` plane. ``plane_factory(case, site)``
    builds the plane (default pymunk's ``world.World``)."""

    name = "pymunk"
    takes_actions = True
    invasion_of = None  # the crews standing in the area (``construct.invasion``)

    def __init__(self, plane_factory: Callable[[Case, Site], Physics] | None = None):
        self.plane_factory = World if plane_factory is None else plane_factory

    def plane(self, case: Case, site: Site) -> Physics:
        return self.plane_factory(case, site)

    def check(self, engine: Engine) -> None:
        """Both stages run on the physics motion."""

    def begin(self, engine: Engine) -> None:
        """The plane holds all there is."""

    def span_s(self, engine: Engine) -> int:
        return 1

    def quiet(self, engine: Engine) -> bool:
        return engine.world.at_rest and not engine.action_needed

    def move(self, engine: Engine, actions, span: Span) -> None:
        """The moving crews' reaching actions through Eq. 1, then one step of the physics."""
        site, world, sim = engine.site, engine.world, engine.case.simulation
        moving, distance, positions = span.moving, span.distance_m, engine.positions
        if engine.park_idle:  # a parked crew stands still whatever its action
            actions = [a if self.needs_action(engine, c) else move.STAND_STILL
                       for a, c in zip(actions, site.crews, strict=True)]
        move.apply_reaching_actions(world, site, actions)
        if any(moving):
            world.step(sim.step_s, sim.physics_substeps)
            for i in range(len(moving)):
                if moving[i]:
                    x, y, _ = world.pose(i)
                    px, py = positions[i]
                    distance[i] = math.hypot(x - px, y - py)
                    positions[i] = (x, y)

    def needs_action(self, engine: Engine, crew: CrewState) -> bool:
        """Section 3.6.2: every moving crew; with ``park_idle``, one without a target only
        while it stands in a congestion area or makes way (``Engine.make_way``)."""
        if not crew.moving:
            return False
        if engine.park_idle and not crew.scope and crew.status == CrewStatus.REACHING:
            return engine.site.in_congestion_area(*engine.positions[crew.index]) or \
                engine.making_way.get(crew.index, -float("inf")) > engine.site.time_s
        return True

    def position_due(self, engine: Engine, crew: CrewState) -> bool:
        """Every ``position_log_every_s`` (in whole steps)."""
        every = max(1, round(engine.position_log_every_s / engine.case.simulation.step_s))
        return engine.steps % every == 0

    def end_span(self, engine: Engine, span: Span, ctx) -> None:
        """Section 3.6's clock: a second more without a reach for each crew still after a
        target; a crew that moved without one has none."""
        timeouts = span.timeouts
        cap = engine.case.simulation.reevaluate_after_steps
        for crew in engine.site.crews:
            i = crew.index
            if span.moving[i]:
                if span.had_target[i]:
                    if crew.moving and crew.scope:
                        timeouts[i] = tick_reach_clock(crew, 1, cap)
                else:
                    crew.steps_since_reach = 0

    def replan(self, engine: Engine) -> None:
        """The low level reads the values in the next second's observations."""


__all__ = ["Motion", "PhysicsMotion", "register_motion", "registered_motions", "Span", "Second",
           "crew_states", "tick_reach_clock"]
