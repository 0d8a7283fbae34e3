"""The floor a command's episodes run on: ``--fidelity`` and ``--calibration`` of
``cmdp-simulate`` and ``cmdp-evaluate`` (docs/event-floor.md).

``pymunk`` (the default) is the paper's floor, simulated second by second with physics: the
ground truth. ``event`` is the event floor (``cmdp_pymunk.eventfloor``): the same site,
decision table, paces and disruptions, but crews walk shortest paths and time jumps from event
to event (about 50 times faster), with walk times and Eq. 2's invasion calibrated on the
pymunk floor; stage 2 only, and no low level acts on it. ``resolve_floor`` checks the options
against each other and finds the calibration before any episode runs; ``Floor`` is what a
run records of them (``record``), so that no result of the event floor can pass for the
pymunk floor's.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

FIDELITY_HELP = ("the floor the episodes run on: pymunk (the paper's, physics every second: "
                 "the ground truth; default) or event (the event floor: crews walk shortest "
                 "paths and time jumps from event to event, about 50 x faster; calibrated on "
                 "the pymunk floor, see --calibration; stage 2 only, no trained navigator; "
                 "docs/event-floor.md)")
CALIBRATION_HELP = ("with --fidelity event: the event floor's calibration (a .event.toml "
                    "written by cmdp-calibrate; default: <case stem>.event.toml beside the "
                    "case file, else a built-in one fitted on the same floor, else none: the "
                    "run says it is uncalibrated)")


def add_fidelity_options(parser) -> None:
    """``--fidelity {pymunk,event}`` and ``--calibration PATH`` (module doc); a motion
    registered before the parser is made (``cmdp_pymunk.motion.register_motion``) is a choice
    too."""
    from cmdp_pymunk.eventfloor import fidelities

    parser.add_argument("--fidelity", choices=fidelities(), default="pymunk", help=FIDELITY_HELP)
    parser.add_argument("--calibration", type=Path, default=None, metavar="PATH",
                        help=CALIBRATION_HELP)


@dataclass(frozen=True)
class Floor:
    """The floor of a run: its fidelity and, on the event floor, its calibration and where
    that came from (``source``: the file, or "uncalibrated")."""

    fidelity: str = "pymunk"
    calibration: object = None  # eventfloor.Calibration on the event floor, else None
    source: str | None = None

    @property
    def runner_args(self) -> tuple:
        """``EpisodeRunner``'s ``fidelity`` and ``calibration`` (after its first five)."""
        return (self.fidelity, self.calibration)

    @property
    def calibrated(self) -> bool:
        return self.calibration is not None and self.calibration.calibrated

    def calibration_record(self) -> dict | None:
        """The calibration as the run's records keep it (None on the pymunk floor): its file
        (or "uncalibrated"), fingerprint, what it was fitted on and its numbers."""
        if self.calibration is None:
            return None
        c = self.calibration
        return {"file": self.source, "fingerprint": c.fingerprint, "fitted_on": c.fitted_on,
                "crew_types": {name: ct.model_dump() for name, ct in sorted(c.crew_types.items())}}

    def record(self) -> dict:
        """``fidelity`` and ``calibration``, for summary.json and the like."""
        return {"fidelity": self.fidelity, "calibration": self.calibration_record()}

    def label(self) -> str:
        """For the console header: ``pymunk floor`` or ``event floor (calibration FILE)``."""
        if self.fidelity != "event":
            return f"{self.fidelity} floor"
        what = f"calibration {self.source}" if self.calibrated else "uncalibrated"
        return f"event floor ({what}, fingerprint {self.calibration.fingerprint})"

    def uncalibrated_note(self, case_path: Path | None) -> str | None:
        """The line a command prints when the event floor runs uncalibrated (None if not)."""
        if self.fidelity != "event" or self.calibrated:
            return None
        case = f" --case {case_path}" if case_path is not None else ""
        return ("warning: the event floor runs uncalibrated (walks at Eq. 1's time along the "
                "shortest path, no Eq. 2 invasion), so its makespans can sit off the pymunk "
                f"floor's; to calibrate it: cmdp-calibrate{case} (writes the case's "
                ".event.toml), or give one with --calibration")


def resolve_floor(case, case_path: Path | None, fidelity: str, calibration: Path | None,
                  navigators: dict[str, list[str]]) -> Floor:
    """The floor the options ask for, checked before any episode runs; a ValueError naming the
    option and the fix for: ``--calibration`` without ``--fidelity event``, the event floor
    with a trained navigator (``navigators``: the command's option -> its specs; the event floor
    has no low level), and a calibration file that is bad or fitted on another floor."""
    from cmdp_pymunk.cases.load import CaseError
    from cmdp_pymunk.eventfloor import calibration_for, fidelities

    if fidelity not in fidelities():
        raise ValueError(f"--fidelity {fidelity!r} is not one of {', '.join(fidelities())}; fix: "
                         "pymunk (the paper's floor, the default) or event")
    if fidelity != "event":
        if calibration is not None:
            raise ValueError(f"--calibration {calibration}: only the event floor reads a "
                             f"calibration, and this run is on the {fidelity} floor; fix: add "
                             "--fidelity event, or drop --calibration")
        return Floor(fidelity)
    for option, specs in navigators.items():
        trained = [s for s in specs if s != "scripted"]
        if trained:
            raise ValueError(f"--fidelity event: {option} {trained[0]} is a trained low "
                             "level, and the event floor has none (its crews walk shortest "
                             f"paths); fix: use the scripted navigator ({option} scripted), "
                             "or run it with --fidelity pymunk")
    source = calibration_file(case, case_path, calibration)
    try:
        fitted = calibration_for(case, case_path, calibration)
    except CaseError as err:
        where = (f"--calibration {err.source}" if calibration is not None else
                 f"the event floor's calibration {err.source} (found for the case; give "
                 "another with --calibration)")
        raise ValueError(f"{where}: {'; '.join(err.problems)}") from None
    return Floor("event", fitted, str(source) if source is not None else "uncalibrated")


def calibration_file(case, case_path: Path | None, calibration: Path | None) -> Path | None:
    """The file ``eventfloor.calibration_for`` reads for these arguments (None: none, the
    floor runs uncalibrated): a run records the numbers and where they came from."""
    from cmdp_pymunk.eventfloor.calibration import calibration_path

    return calibration_path(case, case_path, calibration)
