"""The run behind ``cmdp-simulate`` (``training/commands/simulate.py``): its arguments as
data, the seeds played (here, on worker processes or on Ray), each seed's files (summary,
events, schedule, MS Project XML, 4D IFC, charts) and the makespans over the seeds; the
command parses its options into ``SimulateArgs`` and calls ``simulate``. What each file
holds is the command's documentation (``cmdp-simulate --help``, docs/simulating.md).
"""
from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

# Only light modules at the top: Ctrl-C during the heavy imports (numpy, pymunk, PettingZoo,
# torch) lands inside the command's main(), which turns it into one line and exit 130.
from training.cli import calendar_of

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
    # who asks for lifts (``cmdp_pymunk.logistics.from_spec``; "case": the case's reorder point)
    logistics: str = "case"

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
    from agents.lift import lifts_decided_by
    from cmdp_pymunk.cost import run_cost_fields
    from cmdp_pymunk.report import (
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
        # who asked for the lifts: the --logistics spec ("case": the case's reorder point)
        "logistics": args.logistics,
        # ... and who decided them in words (under "case" a model with a lift head does)
        "lifts_asked_by": lifts_decided_by(args.logistics, args.evaluator),
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

    def __reduce__(self):
        # The log travels as five columns, not as ~1,750 Event tuples each pickled with its
        # class: pickled in 1.0 ms instead of 3.2 (unpickled in 2.2 ms either way), the
        # same events back.
        return _seed_run, (self.seed, self.summary, tuple(zip(*self.events, strict=True)),
                           self.stuck)


def _seed_run(seed: int, summary: dict | None, columns: tuple, stuck: str) -> SeedRun:
    """A ``SeedRun`` from its pickled form (``SeedRun.__reduce__``)."""
    from cmdp_pymunk.events import Event

    return SeedRun(seed, summary, list(map(Event._make, zip(*columns, strict=True))),
                   stuck)


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
        from media.layout_views import stall_picture

        stall_picture(data["stalled"], case, folder / "stall.png", run.events)
    if args.charts and args.seed_charts:
        from media.charts import draw_run

        draw_run(folder, case)
    if gif is not None:  # its frames are on disk already: finish it and move it in place
        gif.close()
    return data


def seed_cost(data: dict, undisrupted: dict | None) -> dict | None:
    """``summary.json``'s ``disruption_cost`` of a seed (``report.disruption_cost``), from
    its summary and the row of its undisrupted floor; None when not measured."""
    if undisrupted is None:
        return None
    from cmdp_pymunk.report import disruption_cost

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
    frames are written as they come (``media.gif.GifStream``), so an episode longer than
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


class Stopped(Exception):
    """An episode that cannot go on (its low level got stuck, its worker was lost): leave the
    backend (its workers stop now) and exit 1 with this line."""


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


def simulate(args: SimulateArgs, progress: Progress) -> int:
    """The whole run: inputs checked, the backend opened, the seeds played and written, the
    makespans over the seeds; returns the exit status (1 if an episode stalled or timed out).
    ``BadInput`` (exit 2) before any episode, ``Stopped`` (exit 1) when one cannot go on,
    ``BackendError`` (exit 2) when the workers or Ray cannot run them."""
    from agents.specs import make_navigator
    from training.runs.backends import open_backend
    from training.runs.base import collecting_less
    from training.runs.runner import make_engine

    inputs = load_inputs(args)
    case, floor, evaluator = inputs.case, inputs.floor, inputs.evaluator
    # The scripted navigator only parks idle crews: let the engine skip their seconds
    # (park_idle); it reads the state, not the rays, so none are cast. A trained navigator gets
    # every crew's decision, as in the paper. The workers build their engines with the same
    # options; this one checks the navigator and renders the GIF's seed.
    runner_args = (case, args.stall_s, args.max_time_s, args.deterministic,
                   POSITION_LOG_EVERY_S, *floor.runner_args, args.logistics)
    workers = args.workers or (1 if args.ray is None else None)
    # Workers (and Ray) start before CP-SAT: an unreachable cluster fails before any work.
    with open_backend(_simulate_job, runner_args, workers, args.ray) as pool:
        cpsat = solve_cpsat(args, case, evaluator)
        try:  # the evaluator is prepared for the case here (a misfit: exit 2)
            engine = make_engine(case, evaluator, args.navigator, args.max_time_s,
                                 POSITION_LOG_EVERY_S, *floor.runner_args, args.logistics)
            navigator = make_navigator(args.navigator, engine, args.deterministic)
        except ValueError as err:
            raise BadInput(str(err)) from None
        spec = args.evaluator
        if args.evaluator == "cpsat":  # the workers replay the plan solved here
            from agents.cpsat import save_plan

            spec = f"cpsat:{save_plan(args.out / 'cpsat_plan.json', case, cpsat)}"
        check_workers(args, case, spec, pool)
        args.out.mkdir(parents=True, exist_ok=True)
        write_json(args.out / "case.json", case.model_dump(mode="json"))
        progress.out = args.out
        announce(args, inputs, pool)
        with collecting_less():  # thousands of events a seed, held until written
            rows, finishes, failed = play_seeds(args, case, inputs.case_label, inputs.lb,
                                                cpsat, spec, engine, navigator, pool,
                                                progress, floor)
    progress.doing, progress.resume = "while writing makespans.csv", ""
    if args.episodes > 1:
        stats = write_makespans(args.out, rows, case.calendar)
        if args.charts:
            from media.episodes import draw_episodes

            draw_episodes(args.out, stats, finishes, len(case.tasks), case.calendar)
    report_files(args, case)
    return 1 if failed else 0


def report_files(args: SimulateArgs, case) -> None:
    """The run's last lines: where the GIF, the MS Project schedule, the 4D model, the
    charts and the tables are."""
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


def measures_cost(args: SimulateArgs, case) -> bool:
    """Whether each seed is also played without the case's disruptions (module doc)."""
    return args.disruption_cost and bool(case.disruptions)


def play_seeds(args: SimulateArgs, case, case_label: str, lb, cpsat, spec: str, engine,
              navigator, pool, progress: Progress,
              floor=None) -> tuple[list[dict], list[list[float]], bool]:
    """Every seed, in seed order: the GIF's seed played on ``engine`` here, the others on
    ``pool``
    (the backend's results come back in job order, so seed folders are written in seed order
    and a stopped run keeps seeds SEED ... K, each folder complete). Returns the summaries,
    each seed's task finish times and whether any episode stalled or timed out."""
    from tqdm import tqdm

    from cmdp_pymunk import interrupt
    from cmdp_pymunk.schedule import finish_times
    from training.runs.backends import WorkerLost, Workers

    seeds = [args.seed + k for k in range(args.episodes)]
    here = seeds[:1] if args.gif else []  # the GIF's seed: rendered in this process
    # One episode in this process shows its tasks; several show one bar over the episodes.
    in_process = isinstance(pool, Workers) and pool.workers == 1
    progress.runner = pool.runner if in_process else None
    task_bar = args.progress and args.episodes == 1
    cost = measures_cost(args, case)
    remote = pool.imap(_seed_jobs(seeds, here, cost, spec, args, case_label, lb,
                                  task_bar and in_process))
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
                    from media.gif import GifStream

                    gif = GifStream(folder / "rollout.gif", 1.0 / GIF_FPS)
                    run = _play_here(engine, navigator, seed, args, case, case_label, lb,
                                     task_bar, gif, progress)
                try:
                    if seed not in here:
                        run = next(remote)
                        if in_process:  # its episode is over: no time under way to report
                            pool.runner.playing = None
                    base = next(remote) if cost else None  # the seed without disruptions
                except WorkerLost:
                    raise Stopped(f"seed {seed}: lost with its worker (it died twice); seeds "
                                f"before it are kept in {args.out}; to finish, rerun with "
                                f"--seed {seed} --episodes {args.episodes - k}") from None
                if run.stuck:
                    raise Stopped(f"seed {seed}: {run.stuck}")
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
            failed = _seed_line(bar, seed, data, folder, case) or failed
    return rows, finishes, failed


def _seed_jobs(seeds: list[int], here: list[int], cost: bool, spec: str, args: SimulateArgs,
               case_label: str, lb, task_bar: bool) -> list[tuple]:
    """In seed order, each seed's floor (but the GIF's, played ``here``) and then, for what the
    disruptions cost, the same seed without them: the backend hands results back in this
    order."""
    jobs = []
    for seed in seeds:
        if seed not in here:
            jobs.append((spec, args, case_label, lb, seed, task_bar))
        if cost:
            jobs.append((spec, args, case_label, lb, seed, False, True))
    return jobs


def _play_here(engine, navigator, seed: int, args: SimulateArgs, case, case_label: str, lb,
               task_bar: bool, gif, progress: Progress) -> SeedRun:
    """The GIF's seed, played on this process's ``engine``, its frames into ``gif`` as they
    are drawn; a policy that got stuck gives a run that says so."""
    from agents.models import PolicyStuck
    from cmdp_pymunk.rollout import run_episode
    from media.render import draw_frame

    progress.engine = engine
    try:
        episode = run_episode(engine, navigator, seed, args.stall_s, task_bar,
                              frame_interval(case, lb), on_frame=gif.append,
                              render=draw_frame)
        run = seed_run(engine, episode, args, case_label, lb)
    except PolicyStuck as err:
        run = SeedRun(seed, None, [], str(err))
    progress.engine = None
    return run


def _seed_line(bar, seed: int, data: dict, folder: Path, case) -> bool:
    """A seed's line on the console (stalled, cut by the time limit, or its makespan and
    finish) and its disruptions' cost; returns whether the seed failed."""
    from cmdp_pymunk.report import seconds_and_hours, stall_text

    failed = False
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
    return failed


def cost_text(data: dict) -> str:
    """A seed's disruptions and their cost, for the console."""
    from cmdp_pymunk.report import seconds_and_hours, struck_text

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
    from cmdp_pymunk.report import makespan_stats, seconds_and_hours
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
    from cmdp_pymunk.report import struck_text

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
