"""``cmdp-simulate``: simulate a whole floor without training, and look at the result.

    cmdp-simulate [--case FILE] [--evaluator priority|nearest|ga:PATH|cpsat|MODEL.zip]
                  [--navigator scripted|MODEL.zip] [--seed N] [--episodes N] [--out DIR] [--gif]
                  [--workers N] [--ray [ADDRESS]] [--fidelity pymunk|event [--calibration PATH]]
                  [--cpsat-s SECONDS] [--ifc MODEL.ifc [--ifc-start ISO-DATETIME]]
                  [--calendar FILE.toml] [--start ISO-DATETIME] [--working-hours HH:MM-HH:MM]
                  [--working-days DAYS] [--holidays DATES]

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

An episode that stops making progress (no task moves on for ``--stall-s`` simulated seconds)
is stopped and reported in prose (``rollout.stall_text``: when, each walking crew's target and
how far it stands from it, what the others do, the tasks on and queued) with a picture,
``stall.png`` in its folder (``media.charts.stall_picture``: the crews where they stand, the
targets, the ways they meant to walk, their last minutes of path), drawn even with
``--no-charts``; ``summary.json``'s ``stalled`` keeps the report as data. The command then
exits with 1.
A bad case file exits with 2 and a message naming the file, the entry and the fix.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

# Only light modules at the top: Ctrl-C during the heavy imports (numpy, pymunk, PettingZoo,
# torch) lands inside main(), which turns it into one line and exit 130.
from training.cli import (
    OneLineParser,
    add_calendar_options,
    add_ray_option,
    calendar_of,
    non_negative_int,
    plain,
    positive_int,
    positive_seconds,
)

DEFAULT_IFC_START = "2026-01-05T08:00:00"  # second 0 of the 4D export without a calendar
MSPDI_FILE = "schedule.xml"  # the schedule as MS Project XML (cmdp_pymunk.exchange.mspdi)
GIF_SECONDS = 30.0
GIF_FPS = 10
POSITION_LOG_EVERY_S = 5.0


@dataclass(frozen=True)
class SimulateArgs:
    """Arguments of ``cmdp-simulate`` (see the module doc)."""

    case: Path | None = None
    evaluator: str = "priority"
    navigator: str = "scripted"
    seed: int = 0
    episodes: int = 1
    out: Path = Path("out/simulate")
    gif: bool = False
    stall_s: float = 3600.0
    max_time_s: float | None = None
    charts: bool = True
    progress: bool = True
    deterministic: bool = False
    cpsat_s: float | None = None
    ifc: Path | None = None
    ifc_start: str | None = None
    workers: int | None = None  # None: this process (local), every CPU of the cluster (Ray)
    ray: str | None = None  # None: worker processes here; "local": a Ray started here
    # the working calendar (None: the case's, or none); ifc_start None: DEFAULT_IFC_START
    calendar: Path | None = None
    start: str | None = None
    working_hours: str | None = None
    working_days: str | None = None
    holidays: str | None = None
    disruption_cost: bool = True  # a disrupted case's floors also played without (module doc)
    fidelity: str = "pymunk"  # the floor: the paper's, or the event floor (training/fidelity.py)
    calibration: Path | None = None  # the event floor's (None: the case's, if any)
    seed_charts: bool = True  # each seed's Gantt charts and trajectories (with ``charts``)


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
    p.add_argument("--stochastic", action="store_true",
                   help="accepted for old scripts; sampling is the default now")
    a = p.parse_args(argv)
    return SimulateArgs(a.case, a.evaluator, a.navigator, a.seed, a.episodes, a.out, a.gif,
                        a.stall_s, a.max_time_s, not a.no_charts, not a.no_progress,
                        a.deterministic, a.cpsat_s, a.ifc, a.ifc_start, a.workers, a.ray,
                        a.calendar, a.start, a.working_hours, a.working_days, a.holidays,
                        not a.no_disruption_cost, a.fidelity, a.calibration,
                        not a.no_seed_charts)


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


def calendar_line(calendar) -> str:
    """``calendar 08:00-16:00 Mon-Fri, second 0 = Fri 2026-01-09 15:00`` (and, when the start
    is not working time, that it was moved)."""
    from cmdp_pymunk.workcalendar import describe, first_working_moment

    zero = first_working_moment(calendar)
    moved = "" if zero == calendar.start else \
        f" (the start {calendar.start:%a %Y-%m-%d %H:%M} is not working time: moved to the " \
        "next working moment)"
    return f"calendar {describe(calendar)}, second 0 = {zero:%a %Y-%m-%d %H:%M}{moved}"


def mspdi_dates(calendar) -> str:
    """Where ``schedule.xml``'s dates come from, for the console: the run's calendar, or
    the documented default when it has none."""
    from cmdp_pymunk.exchange.mspdi import default_calendar
    from cmdp_pymunk.workcalendar import describe, first_working_moment

    if calendar is not None:
        return f"dated from {first_working_moment(calendar):%a %Y-%m-%d %H:%M} by the calendar"
    default = default_calendar()
    return (f"no --start given: dated from the default start "
            f"{first_working_moment(default):%a %Y-%m-%d %H:%M}, working "
            f"{describe(default)} (--start gives the site's)")


def summary(engine, episode, args: SimulateArgs, case_label: str, lb, cpsat=None) -> dict:
    from cmdp_pymunk.cost import run_cost_fields
    from cmdp_pymunk.rollout import (
        crew_summary,
        disruption_summary,
        episode_reach_rate,
        episode_seed_bound,
        versions,
    )
    from cmdp_pymunk.timeuse import time_use

    site = engine.site
    makespan = episode.makespan_s
    seed_bound = episode_seed_bound(engine)
    data = {
        "case": site.case.case.name, "case_file": case_label, "seed": episode.seed,
        "stage": engine.stage,
        # the floor it ran on: "pymunk" (the paper's) or "event" (calibration: its file,
        # fingerprint and numbers, filled in by ``write_outputs``; None on the pymunk floor)
        "fidelity": engine.motion.name, "calibration": None,
        "evaluator": args.evaluator, "navigator": args.navigator,
        "navigator_sampling": "deterministic" if args.deterministic else "stochastic",
        "makespan_s": makespan,
        # what the floor cost beside its makespan (docs/levers.md, "Cost beside time")
        **run_cost_fields(site.case, makespan if site.done else None, engine.log.events),
        "tasks_finished": site.tasks_ended, "tasks_total": len(site.tasks),
        "all_finished": site.done, "simulated_s": site.time_s,
        "lower_bound": lb.as_dict(),
        "makespan_over_lower_bound": makespan / lb.lower_bound_s if makespan else None,
        # the bound on this seed's floor: its drawn paces, loading, critical path (issue 32)
        "seed_bound_s": seed_bound.seed_bound_s if seed_bound else None,
        "seed_bound_binding": seed_bound.binding if seed_bound else None,
        "makespan_over_seed_bound": makespan / seed_bound.seed_bound_s
        if makespan and seed_bound else None,
        "reach_rate": episode_reach_rate(engine),
        "crews": crew_summary(engine),
        "time_use_s": time_use(engine.log.events, {c.id: c.type for c in site.crews},
                               len(site.tasks), site.time_s),
        # what struck, per kind (None for a case without disruptions); what it cost is added
        # where both floors of the seed are known (``write_outputs``)
        "disruptions": disruption_summary(engine),
        "stalled": episode.stalled,
        "lookahead": planner_summary(engine.evaluator, "lookahead"),
        "replan": planner_summary(engine.evaluator, "replan"),
        "wall_s": round(episode.wall_s, 3),
        "simulated_s_per_wall_s": round(site.time_s / episode.wall_s, 1)
        if episode.wall_s > 0 else None,
        "versions": versions(),
    }
    if cpsat is not None:
        data["cpsat"] = cpsat.as_dict()
        data["makespan_over_cpsat_bound"] = makespan / cpsat.bound_s \
            if makespan and cpsat.bound_s > 0 else None
    return data


def write_json(path: Path, data) -> None:
    from cmdp_pymunk.events import write_atomic

    write_atomic(path, json.dumps(data, indent=2) + "\n")


@dataclass(frozen=True)
class SeedRun:
    """One seed's episode as a worker sends it back: ``summary.json``'s data without CP-SAT's
    keys (None when the low level got stuck, ``stuck`` says how) and the event log."""

    seed: int
    summary: dict | None
    events: list
    stuck: str = ""


def seed_run(engine, episode, args: SimulateArgs, case_label: str, lb) -> SeedRun:
    """What is kept of a finished (or stalled) episode on ``engine``."""
    return SeedRun(episode.seed, summary(engine, episode, args, case_label, lb),
                   list(engine.log.events))


def _simulate_job(runner, evaluator_spec: str, args: SimulateArgs, case_label: str, lb,
                  seed: int, progress: bool, undisrupted: bool = False) -> SeedRun | dict:
    """One seed in a worker (``training.runs.runner.open_backend``): played on the worker's
    engine. ``undisrupted``: the seed on the case without its disruptions, for what they cost;
    returns its episode row (``training.runs.runner.episode_row``)."""
    from agents.models import PolicyStuck

    if undisrupted:
        return runner.run(evaluator_spec, args.navigator, seed, undisrupted=True)
    try:
        engine, episode = runner.play(evaluator_spec, args.navigator, seed, progress)
    except PolicyStuck as err:
        return SeedRun(seed, None, [], str(err))
    return seed_run(engine, episode, args, case_label, lb)


def write_outputs(run: SeedRun, folder: Path, args: SimulateArgs, case, cpsat=None,
                  gif=None, undisrupted: dict | None = None, floor=None) -> dict:
    """Every file of one seed into ``folder``, each atomically; ``gif``: its ``GifStream``,
    finished here; ``undisrupted``: the episode row of the same seed on the case without its
    disruptions (``disruption_cost``; None: not measured); ``floor``: the run's
    ``training.fidelity.Floor``, whose calibration (file, fingerprint, numbers) goes into
    ``summary.json`` beside the fidelity the episode ran at. Returns ``summary.json``'s
    data."""
    from cmdp_pymunk.events import EventLog, write_atomic
    from cmdp_pymunk.exchange.mspdi import write_mspdi
    from cmdp_pymunk.schedule import schedule_csv

    folder.mkdir(parents=True, exist_ok=True)
    data = dict(run.summary)
    if floor is not None:
        data["calibration"] = floor.calibration_record()
    data["disruption_cost"] = seed_cost(data, undisrupted)
    if cpsat is not None:
        makespan = data["makespan_s"]
        data["cpsat"] = cpsat.as_dict()
        data["makespan_over_cpsat_bound"] = makespan / cpsat.bound_s \
            if makespan and cpsat.bound_s > 0 else None
    if case.calendar is not None:  # the calendar used, second 0 and the finish date
        from cmdp_pymunk.workcalendar import calendar_summary

        data["calendar"] = calendar_summary(case.calendar, data["makespan_s"],
                                            data.get("simulated_s"))
    log = EventLog()
    log.events = run.events
    log.write_csv(folder / "events.csv")
    write_atomic(folder / "schedule.csv",
                 schedule_csv(run.events, case, data.get("simulated_s")))
    # the same schedule for MS Project and the tools that read its XML (module doc)
    write_mspdi(folder / MSPDI_FILE, run.events, case, data.get("simulated_s"))
    write_json(folder / "summary.json", data)
    if args.ifc is not None:
        import datetime

        from cmdp_pymunk.cases.ifc_export import export_4d
        from cmdp_pymunk.schedule import task_bars

        start = None if case.calendar is not None else \
            datetime.datetime.fromisoformat(args.ifc_start or DEFAULT_IFC_START)
        export_4d(args.ifc, case, task_bars(run.events),
                  folder / f"{args.ifc.stem}-4d.ifc", start)
    if data["stalled"]:  # where it stuck, drawn even without charts: the first thing to see
        from media.charts import stall_picture

        stall_picture(data["stalled"], case, folder / "stall.png", run.events)
    if args.charts and args.seed_charts:
        from media.charts import draw_run

        draw_run(folder, case)
    if gif is not None:  # its frames are on disk already: finish it and move it in place
        gif.close()
    return data


def seed_cost(data: dict, undisrupted: dict | None) -> dict | None:
    """``summary.json``'s ``disruption_cost`` of a seed (``rollout.disruption_cost``), from
    its summary and the row of its undisrupted floor; None when not measured."""
    if undisrupted is None:
        return None
    from cmdp_pymunk.rollout import disruption_cost

    cost = disruption_cost(data["makespan_s"], undisrupted["makespan_s"], data["disruptions"])
    cost["undisrupted_finished"] = undisrupted["finished"]
    return cost


def planner_summary(evaluator, kind: str) -> dict | None:
    """What the lookahead or the re-planning solver did on the floor, each under its own key
    of summary.json (None for any other evaluator)."""
    if kind == "lookahead":
        from agents.lookahead import LookaheadEvaluator as planner
    else:
        from agents.replan import ReplanEvaluator as planner
    return evaluator.summary() if isinstance(evaluator, planner) else None


def frame_interval(case, lb) -> float:
    """Simulated seconds between GIF frames, so the floor plays in GIF_SECONDS or less.

    Sized on three times the lower bound (heuristic makespans sit at about twice it). The
    frames are written as they come (``media.charts.GifStream``), so an episode longer than
    that plays longer.
    """
    return max(case.simulation.step_s, math.ceil(3 * lb.lower_bound_s / (GIF_SECONDS * GIF_FPS)))


@dataclass
class Progress:
    """What ``cmdp-simulate`` is doing and what it has kept, for the line Ctrl-C prints."""

    doing: str = "while starting"
    engine: object = None  # the engine of the episode under way, for its time
    runner: object = None  # the runner playing the episodes in this process (its env's time)
    out: Path | None = None
    kept: list[int] = field(default_factory=list)  # seeds whose folders are complete
    resume: str = ""

    def interrupted(self) -> str:
        doing = self.doing
        engine = self.engine
        if engine is None and self.runner is not None and self.runner.playing is not None:
            engine = self.runner.playing
        site = engine.site if engine is not None else None
        if site is not None:
            doing += f" at t = {site.time_s:,.0f} s"
        if not self.kept:
            kept = "nothing kept" if self.out is None else \
                f"no episode finished, nothing kept in {self.out} but case.json"
        else:
            seeds = (f"seed {self.kept[0]}" if len(self.kept) == 1
                     else f"seeds {self.kept[0]}-{self.kept[-1]}")
            kept = f"kept {seeds} in {self.out} (each folder complete)"
        return f"interrupted {doing}; {kept}{self.resume}"


def main(argv: list[str] | None = None) -> int:
    """The command; Ctrl-C at any moment ends it with one line and exit status 130."""
    progress = Progress()
    try:
        from cmdp_pymunk.interrupt import sigint_guard

        with sigint_guard():
            return _main(argv, progress)
    except KeyboardInterrupt:
        print(f"\ncmdp-simulate: {progress.interrupted()}", file=sys.stderr)
        return 130


class _Stop(Exception):
    """An episode that cannot go on (its low level got stuck, its worker was lost): leave the
    backend (its workers stop now) and exit 1 with this line."""


def _main(argv: list[str] | None, progress: Progress) -> int:
    import cmdp_pymunk
    from agents.specs import make_evaluator, make_navigator
    from cmdp_pymunk.bounds import lower_bound
    from training.fidelity import resolve_floor
    from training.runs.backends import BackendError, open_backend
    from training.runs.runner import make_engine

    args = parse_args(argv)
    try:
        case = with_calendar(cmdp_pymunk.load_case(args.case), args)
        # the floor (--fidelity, --calibration): checked and its calibration found before
        # anything is built or run
        floor = resolve_floor(case, args.case, args.fidelity, args.calibration,
                              {"--navigator": [args.navigator]})
        evaluator = make_evaluator(args.evaluator)
        if args.ifc is not None:  # before simulating: a model that cannot take it fails now
            from cmdp_pymunk.cases.ifc_export import open_for_4d
            from cmdp_pymunk.cases.ifc_import import IfcUnavailable

            try:
                open_for_4d(args.ifc, case)
            except IfcUnavailable as err:  # the message says how to install the extra
                raise ValueError(str(err)) from None
    except cmdp_pymunk.CaseError as err:
        print(f"cmdp-simulate: {err}", file=sys.stderr)
        return 2
    except ValueError as err:
        print(f"cmdp-simulate: {err}", file=sys.stderr)
        return 2
    case_label = str(args.case) if args.case else "built-in (precast_floor.toml)"
    lb = lower_bound(case)
    # The scripted navigator only parks idle crews: let the engine skip their seconds
    # (park_idle); it reads the state, not the rays, so none are cast. A trained navigator gets
    # every crew's decision, as in the paper. The workers build their engines with the same
    # options; this one checks the navigator and renders the GIF's seed.
    runner_args = (case, args.stall_s, args.max_time_s, args.deterministic,
                   POSITION_LOG_EVERY_S, *floor.runner_args)
    workers = args.workers or (1 if args.ray is None else None)
    try:
        # Workers (and Ray) start before CP-SAT: an unreachable cluster fails before any work.
        with open_backend(_simulate_job, runner_args, workers, args.ray) as pool:
            cpsat = None
            if args.cpsat_s is not None or args.evaluator == "cpsat":
                from agents.cpsat import DEFAULT_TIME_LIMIT_S, solve

                cpsat = solve(case, args.cpsat_s or DEFAULT_TIME_LIMIT_S)
                print(f"cmdp-simulate: CP-SAT schedule bound {cpsat.bound_s:.0f} s "
                      f"({'optimal' if cpsat.optimal else 'not proven optimal'}; best schedule "
                      f"{cpsat.makespan_s or float('nan'):.0f} s, {cpsat.wall_s:.1f} s)")
                if args.evaluator == "cpsat":
                    evaluator.use(cpsat)
            try:  # the evaluator is prepared for the case here (a misfit: exit 2)
                engine = make_engine(case, evaluator, args.navigator, args.max_time_s,
                                     POSITION_LOG_EVERY_S, *floor.runner_args)
                navigator = make_navigator(args.navigator, engine, args.deterministic)
            except ValueError as err:
                print(f"cmdp-simulate: {err}", file=sys.stderr)
                return 2
            spec = args.evaluator
            if args.evaluator == "cpsat":  # the workers replay the plan solved here
                from agents.cpsat import save_plan

                spec = f"cpsat:{save_plan(args.out / 'cpsat_plan.json', case, cpsat)}"
            from training.runs.runner import check_worker

            problems = [p for p in pool.check_each(check_worker, [spec], [args.navigator],
                                                   args.deterministic) if p]
            if problems:
                print(f"cmdp-simulate: {problems[0]}; fix: put the file at the same path on "
                      "every node (a shared file system), docs/ray.md", file=sys.stderr)
                return 2
            if measures_cost(args, case):  # an evaluator that cannot play the plain case
                from cmdp_pymunk.disruptions import undisrupted  # fails now, not in a worker
                from training.runs.runner import check_specs

                try:
                    check_specs(undisrupted(case), [spec], [args.navigator], args.deterministic)
                except ValueError as err:
                    print(f"cmdp-simulate: the case without its disruptions (what they cost): "
                          f"{err}; fix: add --no-disruption-cost", file=sys.stderr)
                    return 2
            args.out.mkdir(parents=True, exist_ok=True)
            write_json(args.out / "case.json", case.model_dump(mode="json"))
            progress.out = args.out
            print(f"cmdp-simulate: case {case.case.name!r} ({len(case.crews)} crews, "
                  f"{len(case.tasks)} tasks), lower bound {lb.lower_bound_s:.0f} s, evaluator "
                  f"{args.evaluator}, navigator {args.navigator}, {floor.label()}"
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
            rows, finishes, failed = _episodes(args, case, case_label, lb, cpsat, spec, engine,
                                               navigator, pool, progress, floor)
    except BackendError as err:
        print(f"cmdp-simulate: {err}", file=sys.stderr)
        return 2
    except _Stop as err:
        print(f"cmdp-simulate: {err}", file=sys.stderr)
        return 1
    progress.doing, progress.resume = "while writing makespans.csv", ""
    if args.episodes > 1:
        stats = write_makespans(args.out, rows, case.calendar)
        if args.charts:
            from media.episodes import draw_episodes

            draw_episodes(args.out, stats, finishes, len(case.tasks), case.calendar)
    if args.gif:
        gif = args.out if args.episodes == 1 else args.out / f"seed-{args.seed}"
        print(f"cmdp-simulate: GIF {gif / 'rollout.gif'}")
    where = "" if args.episodes == 1 else " in each seed-K/"
    print(f"cmdp-simulate: MS Project schedule (MSPDI XML) {MSPDI_FILE}{where}, "
          f"{mspdi_dates(case.calendar)}")
    if args.ifc is not None:
        print(f"cmdp-simulate: 4D model (IFC) {args.ifc.stem}-4d.ifc{where}, "
              + ("dated by the calendar" if case.calendar is not None else
                 f"elapsed time from {(args.ifc_start or DEFAULT_IFC_START).replace('T', ' ')}"))
    what = ("charts, summary" if args.charts and (args.seed_charts or args.episodes > 1)
            else "summary")
    print(f"cmdp-simulate: {what}, schedule.csv and events.csv in {args.out}")
    return 1 if failed else 0


def measures_cost(args: SimulateArgs, case) -> bool:
    """Whether each seed is also played without the case's disruptions (module doc)."""
    return args.disruption_cost and bool(case.disruptions)


def _episodes(args: SimulateArgs, case, case_label: str, lb, cpsat, spec: str, engine,
              navigator, pool, progress: Progress,
              floor=None) -> tuple[list[dict], list[list[float]], bool]:
    """Every seed, in seed order: the GIF's seed played on ``engine`` here, the others on
    ``pool``
    (the backend's results come back in job order, so seed folders are written in seed order
    and a stopped run keeps seeds SEED ... K, each folder complete). Returns the summaries,
    each seed's task finish times and whether any episode stalled or timed out."""
    from tqdm import tqdm

    from agents.models import PolicyStuck
    from cmdp_pymunk import interrupt
    from cmdp_pymunk.rollout import run_episode, seconds_and_hours, stall_text
    from cmdp_pymunk.schedule import finish_times
    from training.runs.backends import WorkerLost, Workers

    seeds = [args.seed + k for k in range(args.episodes)]
    here = seeds[:1] if args.gif else []  # the GIF's seed: rendered in this process
    # One episode in this process shows its tasks; several show one bar over the episodes.
    in_process = isinstance(pool, Workers) and pool.workers == 1
    progress.runner = pool.runner if in_process else None
    task_bar = args.progress and args.episodes == 1
    # In seed order, each seed's floor (but the GIF's) and then, for what the disruptions
    # cost, the same seed without them: the backend hands results back in this order.
    cost = measures_cost(args, case)
    jobs = []
    for seed in seeds:
        if seed not in here:
            jobs.append((spec, args, case_label, lb, seed, task_bar and in_process))
        if cost:
            jobs.append((spec, args, case_label, lb, seed, False, True))
    remote = pool.imap(jobs)
    bar = tqdm(total=args.episodes, unit="episode", mininterval=1.0, desc="cmdp-simulate",
               disable=not args.progress or args.episodes == 1)
    rows, finishes, failed = [], [], False
    with bar:
        for k, seed in enumerate(seeds):
            folder = args.out if args.episodes == 1 else args.out / f"seed-{seed}"
            progress.doing = f"in seed {seed}"
            progress.resume = (f"; to finish, rerun with --seed {seed} --episodes "
                               f"{args.episodes - k}" if args.episodes > 1 else "")
            # The GIF's frames go to a temporary file as they are drawn, renamed with the
            # seed's other files; a crash or Ctrl-C deletes it (no half GIF, no frame held in
            # memory).
            gif, made_folder = None, not folder.exists()
            try:
                if seed in here:
                    from media.charts import GifStream
                    from media.render import draw_frame

                    gif = GifStream(folder / "rollout.gif", 1.0 / GIF_FPS)
                    progress.engine = engine
                    try:
                        episode = run_episode(engine, navigator, seed, args.stall_s, task_bar,
                                              frame_interval(case, lb), on_frame=gif.append,
                                              render=draw_frame)
                        run = seed_run(engine, episode, args, case_label, lb)
                    except PolicyStuck as err:
                        run = SeedRun(seed, None, [], str(err))
                    progress.engine = None
                try:
                    if seed not in here:
                        run = next(remote)
                        if in_process:  # its episode is over: no time under way to report
                            pool.runner.playing = None
                    base = next(remote) if cost else None  # the seed without disruptions
                except WorkerLost:
                    raise _Stop(f"seed {seed}: lost with its worker (it died twice); seeds "
                                f"before it are kept in {args.out}; to finish, rerun with "
                                f"--seed {seed} --episodes {args.episodes - k}") from None
                if run.stuck:
                    raise _Stop(f"seed {seed}: {run.stuck}")
                progress.doing = f"while writing seed {seed}'s files"
                # A Ctrl-C while a seed's files are written is held until all of them are: a
                # seed's folder is either complete or not started.
                interrupt.enter()
                try:
                    data = write_outputs(run, folder, args, case, cpsat, gif, base, floor)
                finally:
                    interrupt.leave()
            except BaseException:
                if gif is not None:
                    gif.abort()
                if made_folder and folder.is_dir() and not any(folder.iterdir()):
                    folder.rmdir()  # a seed's folder is complete or absent
                raise
            bar.update(1)
            progress.kept.append(seed)
            rows.append(data)
            finishes.append(finish_times(run.events))
            if data["stalled"]:
                failed = True
                bar.write(f"cmdp-simulate: seed {seed}: STALLED (the picture: "
                          f"{folder / 'stall.png'})\n" + stall_text(data["stalled"]),
                          file=sys.stderr)
            elif not data["all_finished"]:
                failed = True
                bar.write(f"cmdp-simulate: seed {seed}: time limit reached with "
                          f"{data['tasks_finished']}/{len(case.tasks)} tasks finished",
                          file=sys.stderr)
            else:
                finish = (data.get("calendar") or {}).get("finish")
                bar.write(f"cmdp-simulate: seed {seed}: makespan "
                          f"{seconds_and_hours(data['makespan_s'])} "
                          f"({data['makespan_over_lower_bound']:.2f} x lower bound"
                          + (f", {data['makespan_over_seed_bound']:.2f} x seed bound "
                             f"{data['seed_bound_s']:,.0f} s"
                             if data.get("makespan_over_seed_bound") else "") + "), "
                          + (f"finish {finish.replace('T', ' ')[:16]}, " if finish else "")
                          + f"{data['simulated_s_per_wall_s']:.0f} x real time -> {folder}",
                          file=sys.stdout)
            if data["disruptions"] is not None:
                bar.write(f"cmdp-simulate: seed {seed}: {cost_text(data)}", file=sys.stdout)
    return rows, finishes, failed


def cost_text(data: dict) -> str:
    """A seed's disruptions and their cost, for the console."""
    from cmdp_pymunk.rollout import seconds_and_hours, struck_text

    text = struck_text(data["disruptions"])
    cost = data["disruption_cost"]
    if cost is None:
        return f"{text}; cost not measured (--no-disruption-cost)"
    if cost["delay_s"] is None:
        return (f"{text}; cost unknown: the floor "
                + ("without them" if not cost["undisrupted_finished"] else "with them")
                + " did not finish")
    return (f"{text}; they cost {cost['delay_s']:+,.0f} s ({cost['delay_pct']:+.1f} %) against "
            f"{seconds_and_hours(cost['undisrupted_makespan_s'])} on the same seed without them")


def write_makespans(out: Path, rows: list[dict], calendar=None) -> dict:
    """``makespans.csv`` (a row per seed) and ``makespans.json`` (``makespan_stats``, the
    disruptions and their cost); with a working calendar, the finish dates too: a ``finish``
    column and a ``calendar`` entry dating the mean, P50/P80/P90, min and max."""
    from cmdp_pymunk.cost import cost_percentiles
    from cmdp_pymunk.events import write_atomic
    from cmdp_pymunk.rollout import makespan_stats, seconds_and_hours
    from cmdp_pymunk.workcalendar import calendar_datetime, finish_dates, iso

    costs = [r.get("disruption_cost") for r in rows]
    measured = any(c is not None for c in costs)
    lines = ["seed,makespan_s,makespan_over_lower_bound,tasks_finished,all_finished,reach_rate"
             + (",undisrupted_makespan_s,disruption_delay_s" if measured else "")
             + (",finish" if calendar is not None else "")]
    lines += [f"{r['seed']},{r['makespan_s'] or ''},{r['makespan_over_lower_bound'] or ''},"
              f"{r['tasks_finished']},{r['all_finished']},{r['reach_rate']:.4f}"
              + (f",{_blank(c and c['undisrupted_makespan_s'])},{_blank(c and c['delay_s'])}"
                 if measured else "")
              + ("," + (iso(calendar_datetime(calendar, r["makespan_s"])) if r["makespan_s"]
                        else "") if calendar is not None else "")
              for r, c in zip(rows, costs, strict=True)]
    write_atomic(out / "makespans.csv", "\n".join(lines) + "\n")
    # the floor the episodes ran on first, so that no event-floor result passes for pymunk's
    stats = {"fidelity": rows[0].get("fidelity", "pymunk"),
             "calibration": rows[0].get("calibration"), **makespan_stats(rows),
             **cost_percentiles(rows)}  # cost P50/P80 beside the makespan's
    stats["disruptions"] = mean_struck([r.get("disruptions") for r in rows])
    stats["disruption_cost"] = mean_cost(rows) if measured else None
    stats["calendar"] = finish_dates(calendar, {k: stats[f"{k}_s"] for k in (
        "mean", "p50", "p80", "p90", "min", "max")}) if calendar is not None else None
    write_json(out / "makespans.json", stats)
    if stats["finished"]:
        floor = " on the event floor" if stats["fidelity"] == "event" else ""
        print(f"cmdp-simulate: {stats['finished']}/{len(rows)} episodes finished{floor}; "
              "makespan mean "
              f"{seconds_and_hours(stats['mean_s'])}, std {stats['std_s']:.0f} s, min "
              f"{stats['min_s']:.0f}, max {stats['max_s']:.0f} "
              f"({stats['mean_over_lower_bound']:.2f} x lower bound"
              + (f", {stats['mean_over_seed_bound']:.2f} x seed bound, mean "
                 f"{stats['seed_bound_mean_s']:,.0f} s" if stats["mean_over_seed_bound"] else "")
              + "); "
              f"P50 {stats['p50_s']:.0f} s, P80 {stats['p80_s']:.0f} s, "
              f"P90 {stats['p90_s']:.0f} s")
    if stats["calendar"] is not None and stats["finished"]:
        dates = stats["calendar"]
        print(f"cmdp-simulate: finish dates from {dates['second_0']} ({dates['working_time']}): "
              f"P50 {dates['p50']}, P80 {dates['p80']}, P90 {dates['p90']}")
    if stats["disruptions"] is not None:
        print(f"cmdp-simulate: {mean_cost_text(stats)}")
    if stats["percentiles_note"]:
        print(f"cmdp-simulate: warning: {stats['percentiles_note']}", file=sys.stderr)
    return stats


def _blank(value) -> str:
    return "" if value is None else str(value)


def mean_struck(by_seed: list[dict | None]) -> dict | None:
    """Per kind, the mean over the floors of ``disruption_summary``'s numbers (count,
    downtime_s, idle_crew_s); None for a case without disruptions."""
    import numpy as np

    kept = [d for d in by_seed if d is not None]
    if not kept:
        return None
    return {kind: {what: float(np.mean([d[kind][what] for d in kept])) for what in kept[0][kind]}
            for kind in kept[0]}


def mean_cost(rows: list[dict]) -> dict:
    """What the disruptions cost over the seeds (``training.runs.paired``): the mean delay
    against the same seeds undisrupted with its 95 % interval (Student's t) over the seeds
    where both floors finished, the mean delay in % with its interval, the mean undisrupted
    makespan and the ratio of the means."""
    from training.runs.paired import mean_ci, paired

    floors = [{"seed": r["seed"], "makespan_s": r["makespan_s"], "finished": r["all_finished"]}
              for r in rows if r.get("disruption_cost")]
    plain = [{"seed": r["seed"], "makespan_s": c["undisrupted_makespan_s"],
              "finished": c["undisrupted_makespan_s"] is not None}
             for r in rows if (c := r.get("disruption_cost"))]
    both = paired(floors, plain)
    pct, _, pct_ci = mean_ci([r["disruption_cost"]["delay_pct"] for r in rows
                              if r.get("disruption_cost")])
    undisrupted, _, _ = mean_ci([c["undisrupted_makespan_s"] for r in rows
                                 if (c := r.get("disruption_cost")) and c["delay_s"] is not None])
    return {"paired_seeds": both["paired_seeds"], "delay_mean_s": both["diff_mean_s"],
            "delay_ci95_s": both["diff_ci95_s"], "delay_pct_mean": pct,
            "delay_pct_ci95": pct_ci, "undisrupted_mean_s": undisrupted,
            "ratio": both["ratio"]}


def mean_cost_text(stats: dict) -> str:
    """The disruptions over the seeds and their mean cost, for the console."""
    from cmdp_pymunk.rollout import struck_text

    text = f"disruptions per floor on average: {struck_text(stats['disruptions'])}"
    cost = stats["disruption_cost"]
    if cost is None:
        return text + "; cost not measured (--no-disruption-cost)"
    if not cost["paired_seeds"]:
        return text + "; cost unknown: no seed finished both with and without them"
    ci = "" if cost["delay_ci95_s"] is None else f" ± {cost['delay_ci95_s']:,.0f}"
    ci_pct = "" if cost["delay_pct_ci95"] is None else f" ± {cost['delay_pct_ci95']:.1f}"
    return (f"{text}; they cost {cost['delay_mean_s']:+,.0f}{ci} s a floor "
            f"({cost['delay_pct_mean']:+.1f}{ci_pct} %; mean, 95 % interval) against "
            f"{cost['undisrupted_mean_s']:,.0f} s on the same {cost['paired_seeds']} seeds "
            "without them")


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
