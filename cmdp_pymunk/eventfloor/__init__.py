"""The event floor: the same construction process without per-second physics (issue 30).

``WalkMotion`` (``floor``) is a motion of the engine (``motion.Motion``): the engine runs a
case's stage-2 CMDP from event to event on the same site, decision table, paces and
disruptions as the pymunk floor; ``EventFloor(case, calibration=...)`` is an engine on it, and
``engine.clone(motion=WalkMotion(...))`` puts any floor on it. Crews walk the shortest paths in the
time Eq. 1 gives (``walks``); what it cannot derive is fitted on the pymunk floor and kept as
data beside the case (``calibration``). ``make_floor(case, fidelity)`` builds either floor.
"""

from .calibration import Calibration, calibration_for, load_calibration, uncalibrated
from .floor import FIDELITIES, EventFloor, WalkMotion, fidelities, make_floor

__all__ = ["EventFloor", "WalkMotion", "make_floor", "FIDELITIES", "fidelities", "Calibration",
           "calibration_for", "load_calibration", "uncalibrated"]
