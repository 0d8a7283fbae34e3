"""What a ``cmdp-simulate`` run needs and checks before any episode: the case with the working
calendar the options give, the floor, the evaluator and the case's lower bound (``Inputs``),
CP-SAT's bound and the plan it replays, every worker able to play, and the run's first lines
saying what it plays. A case with disruptions has each seed also played without them, for
what they cost (``measures_cost``; ``--no-disruption-cost`` skips it).

Apart from the run (``training.runs.simulation``) because all of it happens before anything
is played: bad input fails here (``BadInput``, exit 2), naming the fix.
"""
from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING

# Only light modules at the top: Ctrl-C during the heavy imports (numpy, pymunk, PettingZoo,
# torch) lands inside the command's main(), which turns it into one line and exit 130.
from training.cli import calendar_of

if TYPE_CHECKING:  # annotations only: the run imports this module
    from training.runs.simulation import SimulateArgs


def with_calendar(case, args: SimulateArgs):
    """The case with the working calendar the options give: the case's ``[calendar]``, or
    ``--calendar FILE``'s, with ``--start``, ``--working-hours``, ``--working-days`` and
    ``--holidays`` replacing its entries. ``CaseError`` (exit 2) naming the file or option,
    the entry and the fix."""
    from cmdp_pymunk.cases.load import CaseError

    calendar = calendar_of(case, args)
    if calendar is not None and args.ifc_start is not None:
        raise CaseError("command line", [
            "--ifc-start: a working calendar gives the 4D export its dates, so --ifc-start "
            "(elapsed time from a date) would be ignored; fix: give the start as --start, or "
            "leave the calendar out"])
    if calendar == case.calendar:
        return case
    return case.model_copy(update={"calendar": calendar})


def calendar_line(calendar) -> str:
    """``calendar 08:00-16:00 Mon-Fri, second 0 = Fri 2026-01-09 15:00`` (and, when the start
    is not working time, that it was moved)."""
    from cmdp_pymunk.workcalendar import describe, first_working_moment

    zero = first_working_moment(calendar)
    moved = "" if zero == calendar.start else \
        f" (the start {calendar.start:%a %Y-%m-%d %H:%M} is not working time: moved to the " \
        "next working moment)"
    return f"calendar {describe(calendar)}, second 0 = {zero:%a %Y-%m-%d %H:%M}{moved}"


class BadInput(Exception):
    """A case, option or file found unfit before any episode: exit 2 with this line."""


@dataclass(frozen=True)
class Inputs:
    """What a run needs before anything is built: the case (with its calendar), the floor
    (``training.fidelity.Floor``), the evaluator, the case's label and its lower bound."""

    case: object
    floor: object
    evaluator: object
    case_label: str
    lb: object


def load_inputs(args: SimulateArgs) -> Inputs:
    """The case, the floor (``--fidelity``, ``--calibration``: checked and its calibration
    found before anything is built or run) and the evaluator; ``--ifc``'s model opened, so a
    model that cannot take the schedule fails now. ``BadInput`` naming the fix."""
    import cmdp_pymunk
    from agents.specs import evaluator_from_spec
    from cmdp_pymunk.bounds import lower_bound
    from cmdp_pymunk.logistics import from_spec
    from training.fidelity import resolve_floor

    try:
        case = with_calendar(cmdp_pymunk.load_case(args.case), args)
        floor = resolve_floor(case, args.case, args.fidelity, args.calibration,
                              {"--navigator": [args.navigator]})
        evaluator = evaluator_from_spec(args.evaluator)
        from_spec(args.logistics, case=case)  # a role that misfits the case
        if args.ifc is not None:
            from cmdp_pymunk.cases.ifc_export import open_for_4d
            from cmdp_pymunk.cases.ifc_model import IfcUnavailable

            try:
                open_for_4d(args.ifc, case)
            except IfcUnavailable as err:  # the message says how to install the extra
                raise ValueError(str(err)) from None
    except ValueError as err:  # CaseError is a ValueError
        raise BadInput(str(err)) from None
    case_label = str(args.case) if args.case else "built-in (precast_floor.toml)"
    return Inputs(case, floor, evaluator, case_label, lower_bound(case))


def solve_cpsat(args: SimulateArgs, case, evaluator):
    """CP-SAT's schedule bound (``--cpsat-s``) and the plan ``--evaluator cpsat`` replays,
    announced on the console; None when neither asked for it."""
    if args.cpsat_s is None and args.evaluator != "cpsat":
        return None
    from agents.cpsat import DEFAULT_TIME_LIMIT_S, solve

    cpsat = solve(case, args.cpsat_s or DEFAULT_TIME_LIMIT_S)
    print(f"cmdp-simulate: CP-SAT schedule bound {cpsat.bound_s:.0f} s "
          f"({'optimal' if cpsat.optimal else 'not proven optimal'}; best schedule "
          f"{cpsat.makespan_s or float('nan'):.0f} s, {cpsat.wall_s:.1f} s)")
    if args.evaluator == "cpsat":
        evaluator.use(cpsat)
    return cpsat


def check_workers(args: SimulateArgs, case, spec: str, pool) -> None:
    """Every worker can load the evaluator and the navigator, and with the disruptions' cost
    the evaluator can play the case without them: ``BadInput`` naming the fix."""
    from training.runs.runner import check_worker

    problems = [p for p in pool.check_each(check_worker, [spec], [args.navigator],
                                           args.deterministic) if p]
    if problems:
        raise BadInput(f"{problems[0]}; fix: put the file at the same path on every node (a "
                       "shared file system), docs/ray.md")
    if measures_cost(args, case):  # an evaluator that cannot play the plain case
        from cmdp_pymunk.disruptions import undisrupted  # fails now, not in a worker
        from training.runs.runner import check_specs

        try:
            check_specs(undisrupted(case), [spec], [args.navigator], args.deterministic)
        except ValueError as err:
            raise BadInput(f"the case without its disruptions (what they cost): {err}; fix: "
                           "add --no-disruption-cost") from None


def announce(args: SimulateArgs, inputs: Inputs, pool) -> None:
    """The run's first lines: the case, the bound, the strategy and the floor, and what the
    options leave out or add."""
    from agents.lift import lifts_decided_by

    case, floor = inputs.case, inputs.floor
    print(f"cmdp-simulate: case {case.case.name!r} ({len(case.crews)} crews, "
          f"{len(case.tasks)} tasks), lower bound {inputs.lb.lower_bound_s:.0f} s, evaluator "
          f"{args.evaluator}, navigator {args.navigator}, {floor.label()}, "
          f"logistics {lifts_decided_by(args.logistics, args.evaluator)}"
          + (f"; {args.episodes} episodes, {pool.label}" if args.episodes > 1 else ""),
          flush=True)
    if floor.fidelity == "event" and args.charts and args.seed_charts:
        print("cmdp-simulate: the event floor places crews at events, not along their "
              "walks: no trajectories.png", flush=True)
    if args.episodes >= 100 and args.charts and args.seed_charts:
        print("cmdp-simulate: each seed's Gantt charts take about a second to draw; "
              "--no-seed-charts keeps the histogram and the S-curve alone", flush=True)
    if floor.uncalibrated_note(args.case):
        print(f"cmdp-simulate: {floor.uncalibrated_note(args.case)}", file=sys.stderr,
              flush=True)
    if case.calendar is not None:
        print(f"cmdp-simulate: {calendar_line(case.calendar)}", flush=True)
    if measures_cost(args, case):
        print("cmdp-simulate: the case has disruptions: each seed is also played "
              "without them, for what they cost (--no-disruption-cost to skip)",
              flush=True)


def measures_cost(args: SimulateArgs, case) -> bool:
    """Whether each seed is also played without the case's disruptions (module doc)."""
    return args.disruption_cost and bool(case.disruptions)
