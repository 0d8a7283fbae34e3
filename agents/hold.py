"""Holding a choice that overrides Eq. 9, shared by the student (``agents.student``) and a
masked-choice model saved with ``hold_choice`` (``agents.candidates``).

The engine asks a crew for its values again every ``reevaluate_after_steps`` steps it walks
without reaching a target (``cmdp_pymunk.evaluate.needs_values``). An evaluator that re-decided
there could flip between two targets while walking; so a choice other than Eq. 9's first is
held: later asks are answered with Eq. 9's values and the held target promoted to the top,
until the crew reaches a target (its reach count moves on) or the target leaves the values
(its scope changed). Holds are kept per site, so one evaluator can serve several floors and
the branches of one (``Engine.clone`` makes a new site).
"""

from __future__ import annotations

import weakref

from .lookahead import promote


class HeldChoices:
    """Per site, per crew: the held target and the crew's reach count when it was chosen."""

    def __init__(self):
        self._by_site: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

    def __reduce__(self):  # pickled into lookahead workers: the holds stay behind
        return (HeldChoices, ())

    def values(self, site, crew, values: dict[int, float]) -> dict[int, float] | None:
        """``values`` (Eq. 9's V_Tar of the crew's scope) with the crew's held target
        promoted, while the hold lasts; None when the crew holds nothing (a hold that ended is
        dropped here)."""
        held = self._by_site.get(site)
        if not held or crew.index not in held:
            return None
        target, reaches = held[crew.index]
        if target in values and crew.stats.reaches == reaches:
            return promote(values, target)
        del held[crew.index]
        return None

    def hold(self, site, crew, target: int) -> None:
        """Hold ``target`` (an override of Eq. 9's first choice) for ``crew`` until it reaches
        a target or ``target`` leaves its scope."""
        self._by_site.setdefault(site, {})[crew.index] = (target, crew.stats.reaches)
