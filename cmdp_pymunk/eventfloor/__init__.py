"""The event floor: the same construction process without per-second physics (issue 30).

``EventFloor`` (``floor``) runs a case's stage-2 CMDP from event to event on the same site,
decision table, paces and disruptions as the pymunk floor; crews walk the shortest paths in the
time Eq. 1 gives (``walks``); what it cannot derive is fitted on the pymunk floor and kept as
data beside the case (``calibration``). ``make_floor(case, fidelity)`` builds either floor.
"""

from .calibration import Calibration, calibration_for, load_calibration, uncalibrated
from .floor import FIDELITIES, EventFloor, make_floor

__all__ = ["EventFloor", "make_floor", "FIDELITIES", "Calibration", "calibration_for",
           "load_calibration", "uncalibrated"]
