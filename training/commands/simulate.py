"""``cmdp-simulate``: simulate a whole floor without training, and look at the result.

    cmdp-simulate [--case FILE] [--evaluator priority|nearest|ga:PATH|cpsat|MODEL.zip]
                  [--navigator scripted|MODEL.zip] [--seed N] [--episodes N] [--out DIR] [--gif]
                  [--workers N] [--ray [ADDRESS]] [--fidelity pymunk|event [--calibration PATH]]
                  [--cpsat-s SECONDS] [--ifc MODEL.ifc [--ifc-start ISO-DATETIME]]
                  [--calendar FILE.toml] [--start ISO-DATETIME] [--working-hours HH:MM-HH:MM]
                  [--working-days DAYS] [--holidays DATES]
                  [--logistics case|never|reorder:LIFTS|crane-idle|learned:PATH]

Writes into DIR: ``summary.json`` (makespan, tasks finished, per crew the simulated seconds
it spent reaching and idle by cause (its keys ``reaching_steps`` and ``idle_steps`` count
steps of the case's ``step_s``, 1 s by default), distance, material trips, crane waits, the
makespan lower bound and the ratio to it, seed, case, versions; with ``--cpsat-s`` CP-SAT's
schedule bound, agents/cpsat.py), ``events.csv`` (the event log), ``schedule.csv`` (every task
of the case: its type, component, crew, status, start, end, duration, pauses; unstarted ones
with empty times), ``schedule.xml`` (the same schedule as MS Project XML, MSPDI, with the
precedences as finish-to-start links and the crews as resources:
``cmdp_pymunk.exchange.mspdi``; dated by the working calendar, else from Mon 2026-01-05 08:00
on 08:00-16:00 Mon-Fri), ``gantt_agents.png``, ``gantt_tasks.png``, ``resource_profile.png``
(crews busy per type and the crane's lifts over time), ``trajectories.png`` (an episode that
stalled or reached the time limit says so on its charts instead of a makespan), with ``--gif``
``rollout.gif``, and ``case.json`` (the resolved case). With ``--episodes N`` each episode
(seeds N0, N0 + 1, ...) gets its own ``seed-K/`` folder and DIR gets ``makespans.csv``,
``makespans.json`` (mean, spread, P50/P80/P90), ``makespan_histogram.png`` and ``s_curve.png``
(tasks ended over time, with the spread over seeds). With ``--ifc MODEL.ifc`` (a case made by
``cmdp-import-ifc`` from that model) each episode's folder also gets ``MODEL-4d.ifc``: the
model with the simulated schedule as an IfcWorkSchedule
(``cmdp_pymunk.cases.ifc_export.export_4d``; IFC4 or IFC2X3, as the model), simulated second
0 at ``--ifc-start``.

A working calendar (the case's ``[calendar]``, replaced by ``--calendar FILE.toml``'s, its
entries overridden by ``--start``, ``--working-hours``, ``--working-days``, ``--holidays``;
``--start`` alone gives one with 08:00-16:00, Mon-Fri) turns simulated seconds into dates
(``cmdp_pymunk.workcalendar``): simulated time is working time, second 0 the start or the next
working moment. Then ``schedule.csv`` gets ``start`` and ``end`` dates, the Gantt charts a date
axis, ``summary.json`` a ``calendar`` entry (the calendar, second 0, the finish date),
``makespans.csv`` a ``finish`` date per seed and ``makespans.json`` the dates of the mean,
P50/P80/P90, min and max (its ``calendar`` entry), the 4D
export the calendar's dates, and ``case.json`` the calendar used. Without one nothing changes.

The episodes run through ``cmdp-evaluate``'s episode runner (``training/runs/runner.py``): in this
process (the default, ``--workers 1``), in ``--workers N`` worker processes, or on Ray actors
with ``--ray`` (a Ray started here) or ``--ray ADDRESS`` (a cluster; docs/ray.md). A worker
plays its seed and sends back the summary and the event log; this process writes each seed's
folder (atomically, charts and IFC included) in seed order as the results arrive, under one
progress bar over the episodes. The same seeds give the same files whatever the backend and
the number of workers. The GIF's seed (the first) is played in this process, which renders it.
With ``--evaluator cpsat`` the plan is solved here and saved as ``DIR/cpsat_plan.json``, which
the workers replay.

Disruptions (crane breakdowns, late deliveries, absences, weather stops; docs/disruptions.md)
strike when the case has a ``[disruptions]`` table, e.g. ``--case
cmdp_pymunk/cases/precast_floor_disrupted.toml`` (the built-in floor with a disruption
profile). Then ``summary.json`` says what struck (``disruptions``: per kind, how many, their
downtime and the crew-seconds they kept crews from working) and what it cost
(``disruption_cost``: the makespan of the same seed on the case without its disruptions,
played by the same evaluator and low level on the same backend; every task meets the same
pace in both, so the delay is the disruptions' alone), the console says it per seed, and with
``--episodes N`` ``makespans.json`` gives the mean delay with its 95 % interval. Measuring the
cost plays each floor twice, so it is on only for a case with disruptions (a planner's first
question of one), and ``--no-disruption-cost`` turns it off.

``--fidelity event`` runs the episodes on the event floor (``cmdp_pymunk.eventfloor``,
docs/event-floor.md): crews walk shortest paths and time jumps from event to event, about 50
times faster than the pymunk floor (the default, the paper's, the ground truth), with walk
times and Eq. 2's invasion calibrated on it (``--calibration PATH``; by default the case's
``<stem>.event.toml``, else a built-in one for the same floor, else none: the command says it
runs uncalibrated and how to calibrate, ``cmdp-calibrate``). It is stage 2 without a low
level: a trained ``--navigator`` is refused. ``summary.json`` and ``makespans.json`` record
``fidelity`` and ``calibration`` (its file or "uncalibrated", fingerprint and numbers), the
console header and the charts' titles name the event floor, and its crews are placed at events
only, so there is no ``trajectories.png`` (the GIF shows them jump along their walks). With
``--episodes 1000`` add ``--no-seed-charts``: each seed's Gantt charts take about a second,
the histogram and the S-curve are still drawn.

``--logistics SPEC`` says who decides when a crew fetching at a storage asks for the next
crane lift (``cmdp_pymunk.logistics``, docs/levers.md): ``case`` (the default: the case's
reorder point, or the paper's c7 where it sets none), ``never`` (c7: a lift once the storage
is empty), ``reorder:LIFTS`` (a reorder point at LIFTS crane lifts of each material, e.g.
``reorder:0.5``), ``crane-idle`` (ask when the crane has nothing to do) or ``learned:PATH`` (a
fitted rule, e.g. ``learned:models/logistics_learned.json``). A bad spec exits 2 before
anything runs; ``summary.json`` records it (``logistics``) and the console header shows it.

An episode that stops making progress (no task moves on for ``--stall-s`` simulated seconds)
is stopped and reported in prose (``report.stall_text``: when, each walking crew's target and
how far it stands from it, what the others do, the tasks on and queued) with a picture,
``stall.png`` in its folder (``media.layout_views.stall_picture``: the crews where they stand, the
targets, the ways they meant to walk, their last minutes of path), drawn even with
``--no-charts``; ``summary.json``'s ``stalled`` keeps the report as data. The command then
exits with 1.
A bad case file exits with 2 and a message naming the file, the entry and the fix.
"""

from __future__ import annotations

import sys
from pathlib import Path

# Only light modules at the top: Ctrl-C during the heavy imports (numpy, pymunk, PettingZoo,
# torch) lands inside main(), which turns it into one line and exit 130.
from training.cli import (
    OneLineParser,
    add_calendar_options,
    add_logistics_option,
    add_ray_option,
    non_negative_int,
    plain,
    positive_int,
    positive_seconds,
)
from training.runs.seed_outputs import DEFAULT_IFC_START
from training.runs.simulation import Progress, SimulateArgs


def parse_args(argv: list[str] | None = None) -> SimulateArgs:
    import cmdp_pymunk
    from agents.specs import EVALUATOR_HELP
    from training.fidelity import add_fidelity_options

    p = OneLineParser(prog="cmdp-simulate", description=plain(__doc__), epilog=(
        "Writes into --out: summary.json, events.csv, schedule.csv, schedule.xml (MS "
        "Project XML), case.json, gantt_agents.png, gantt_tasks.png, resource_profile.png, "
        "trajectories.png (--gif: rollout.gif); with "
        "--episodes N each seed in seed-K/, and makespans.csv, makespans.json, "
        "makespan_histogram.png and s_curve.png in --out. Disruptions (crane breakdowns, "
        "late deliveries, absences, weather stops) strike with a case that has a "
        "[disruptions] table, e.g. --case cmdp_pymunk/cases/precast_floor_disrupted.toml "
        "(docs/disruptions.md); summary.json then reports their count, downtime and cost "
        "against the same seed undisrupted (--no-disruption-cost skips that second floor). "
        "Exit status 1 if an episode stalled or timed out, 2 for a bad case or option. "
        "docs/simulating.md"))
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--case", type=Path, default=None, help="case file (default: built-in)")
    p.add_argument("--evaluator", default="priority",
                   help=EVALUATOR_HELP + " (default: priority)")
    p.add_argument("--navigator", default="scripted",
                   help="scripted, or a stage-1 reaching model .zip (default: scripted)")
    p.add_argument("--seed", type=non_negative_int, default=0,
                   help="the (first) episode's seed (default 0)")
    p.add_argument("--episodes", type=positive_int, default=1,
                   help="episodes on seeds SEED, SEED + 1, ...: each in DIR/seed-K, with "
                        "P50/P80/P90, a histogram and an S-curve in DIR (default 1)")
    p.add_argument("--out", type=Path, default=Path("out/simulate"),
                   help="the folder to write into (default out/simulate)")
    p.add_argument("--gif", action="store_true", help="also write rollout.gif")
    p.add_argument("--stall-s", type=positive_seconds, default=3600.0,
                   help="stop an episode in which no task moves on for this long (default 3600)")
    p.add_argument("--max-time-s", type=positive_seconds, default=None,
                   help="time limit per episode (default: the case's)")
    p.add_argument("--no-charts", action="store_true", help="skip the PNG charts")
    p.add_argument("--no-seed-charts", action="store_true",
                   help="skip each seed's Gantt charts and trajectories (about a second a "
                        "seed); with --episodes N the histogram and the S-curve are still "
                        "drawn")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--deterministic", action="store_true",
                   help="a model navigator takes its argmax action instead of sampling (it "
                        "stops with a message when a crew repeats a blocked move)")
    p.add_argument("--cpsat-s", type=positive_seconds, default=None, metavar="SECONDS",
                   help="also solve the case as a schedule with CP-SAT for this long and report "
                        "its proven makespan bound in summary.json (and the plan that "
                        "--evaluator cpsat replays; default for it: 20 s)")
    p.add_argument("--ifc", type=Path, default=None, metavar="MODEL.ifc",
                   help="also write the schedule into a copy of this IFC model (the one the "
                        "case was imported from) as 4D: MODEL-4d.ifc")
    p.add_argument("--ifc-start", type=iso_datetime, default=None,
                   metavar="ISO-DATETIME",
                   help="the date and time of simulated second 0 in the 4D schedule, elapsed "
                        f"time, without a working calendar (default {DEFAULT_IFC_START})")
    add_calendar_options(p, "schedule.csv, the charts, summary.json, makespans.json and the "
                         "4D export")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="worker processes for the episodes, or Ray actors with --ray (default: "
                        "this process; with --ray, every CPU of the Ray)")
    add_ray_option(p)
    p.add_argument("--no-disruption-cost", action="store_true",
                   help="on a case with disruptions, do not also play each seed without them "
                        "(what they cost: summary.json's disruption_cost; measuring it doubles "
                        "the work). A case without disruptions is played once either way")
    add_fidelity_options(p)
    add_logistics_option(p)
    p.add_argument("--stochastic", action="store_true",
                   help="accepted for old scripts; sampling is the default now")
    a = p.parse_args(argv)
    return SimulateArgs(a.case, a.evaluator, a.navigator, a.seed, a.episodes, a.out, a.gif,
                        a.stall_s, a.max_time_s, not a.no_charts, not a.no_progress,
                        a.deterministic, a.cpsat_s, a.ifc, a.ifc_start, a.workers, a.ray,
                        a.calendar, a.start, a.working_hours, a.working_days, a.holidays,
                        not a.no_disruption_cost, a.fidelity, a.calibration,
                        not a.no_seed_charts, a.logistics)


def iso_datetime(text: str) -> str:
    """An ``argparse`` type: an ISO 8601 date and time, e.g. 2026-01-05T08:00:00."""
    import argparse
    import datetime

    try:
        datetime.datetime.fromisoformat(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an ISO date and time; fix: give e.g. "
                                         "2026-01-05T08:00:00") from None
    return text


def main(argv: list[str] | None = None) -> int:
    """The command; Ctrl-C at any moment ends it with one line and exit status 130."""
    progress = Progress()
    try:
        from cmdp_pymunk.interrupt import sigint_guard
        from training.runs.backends import BackendError
        from training.runs.simulation import Stopped, simulate
        from training.runs.simulation_inputs import BadInput

        with sigint_guard():
            args = parse_args(argv)
            try:
                return simulate(args, progress)
            except (BadInput, BackendError) as err:
                print(f"cmdp-simulate: {err}", file=sys.stderr)
                return 2
            except Stopped as err:
                print(f"cmdp-simulate: {err}", file=sys.stderr)
                return 1
    except KeyboardInterrupt:
        print(f"\ncmdp-simulate: {progress.interrupted()}", file=sys.stderr)
        return 130


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
