"""Counting for metrics, beside the dynamics (as Mesa's DataCollector sits beside a model).

The engine's ``step`` returns what happened in one span (``motion.Span``: a simulated second
on the physics motion, the seconds to the next event on the walk motion); ``Counters.count``
turns it into the per-crew counters of the episode (``crew.stats``: the
summaries of ``report.crew_summary`` and the evaluation chapters) and into the counts of the
current call (``window``: ``infos[agent]["step_stats"]``, the training metrics). Nothing here
changes what the simulation does next.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .physics import COMPONENT, CREW, STORAGE, TASK_AREA, WALL
from .state import REACHING, WAITING, Site

if TYPE_CHECKING:
    from .motion import Span

# per-agent counts of one call (one adapter step, however many seconds it ran), for training
STEP_STATS = ("reaches", "timeouts", "reaching", "collisions", "congestion")


def collisions(contacts) -> int:
    """Collisions of one crew in one second: walls, components and crews (section 3.6.2)."""
    return contacts[WALL] + contacts[COMPONENT] + contacts[CREW]


def congestion_entries(contacts) -> int:
    """Entries into congestion areas of one crew in one second: task areas and storages."""
    return contacts[TASK_AREA] + contacts[STORAGE]


class Counters:
    """The episode's per-crew counters and the counts of the current window (one call)."""

    def __init__(self, site: Site):
        self.site = site
        self.reach_cap = site.case.simulation.reevaluate_after_steps
        self.window = [dict.fromkeys(STEP_STATS, 0) for _ in site.crews]
        self._reaches_before = [0] * len(site.crews)

    def open_window(self) -> None:
        """Start counting a new call's ``step_stats`` (a fresh dict per crew)."""
        self.window = [dict.fromkeys(STEP_STATS, 0) for _ in self.site.crews]
        self._reaches_before = [c.stats.reaches for c in self.site.crews]

    def close_window(self) -> None:
        """The reaches of the call (the decision table counts them in ``crew.stats``)."""
        for crew in self.site.crews:
            self.window[crew.index]["reaches"] = crew.stats.reaches - \
                self._reaches_before[crew.index]

    def count(self, span: Span) -> None:
        """Add one span (``motion.Span``, ``span.seconds`` of them): reaching and idle
        seconds, re-evaluation time-outs (a step cap held without reaching), collisions,
        congestion entries, crane waits, distance. A crew's status, disruption and idle cause
        are read from ``span.states`` where the motion took them, else as the crew stands
        now (a second is counted by the state it ends in)."""
        k = span.seconds
        states, moving, had_target = span.states, span.moving, span.had_target
        windows = self.window
        for crew in self.site.crews:
            i = crew.index
            stats = crew.stats
            disruption, status, idle_cause = states[i] if states is not None else \
                (crew.disruption, crew.status, crew.idle_cause)
            if disruption:  # kept from working by a disruption, whatever it does
                stats.idle_steps[disruption] += k
            if moving[i]:
                window = windows[i]
                stats.distance_m += span.distance_m[i]
                if had_target[i]:
                    stats.reaching_steps += k
                    window["reaching"] += k
                    timeouts = span.timeouts[i]  # still after it past a step cap (its clock)
                    if timeouts:
                        stats.reach_timeouts += timeouts
                        window["timeouts"] += timeouts
                elif status == REACHING and idle_cause:
                    stats.idle_steps[idle_cause] += k
                contacts = span.contacts[i]
                if contacts is not None:
                    hits, entries = collisions(contacts), congestion_entries(contacts)
                    stats.collisions += hits
                    stats.congestion_entries += entries
                    window["collisions"] += hits
                    window["congestion"] += entries
            elif status == WAITING:
                stats.crane_wait_steps += k
