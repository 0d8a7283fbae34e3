"""The run behind ``cmdp-simulate`` (``training/commands/simulate.py``): its arguments as
data, the seeds played (here, on worker processes or on Ray) in seed order, each seed's line
on the console and the run's last lines; the command parses its options into ``SimulateArgs``
and calls ``simulate``. What each file holds is the command's documentation
(``cmdp-simulate --help``, docs/simulating.md).

The run's other parts have modules of their own: what it needs and checks before any episode
(``training.runs.simulation_inputs``), a seed's ``summary.json`` data and files
(``training.runs.seed_outputs``) and the makespans over the seeds
(``training.runs.makespans``). The names the command, the benchmarks and the changelog give
as ``training.runs.simulation.X`` are re-imported here (``__all__``).
"""
from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path

# Only light modules at the top (these three import nothing heavy at theirs either): Ctrl-C
# during the heavy imports (numpy, pymunk, PettingZoo, torch) lands inside the command's
# main(), which turns it into one line and exit 130.
from training.runs.makespans import write_makespans
from training.runs.seed_outputs import (
    DEFAULT_IFC_START,
    GIF_FPS,
    MSPDI_FILE,
    SeedRun,
    _simulate_job,
    frame_interval,
    seed_run,
    write_json,
    write_outputs,  # looked up here by play_seeds: benchmarks/bench_simulate_many.py wraps it
)
from training.runs.simulation_inputs import (
    BadInput,
    announce,
    check_workers,
    load_inputs,
    measures_cost,
    solve_cpsat,
)

__all__ = [
    "POSITION_LOG_EVERY_S", "SimulateArgs", "mspdi_dates", "Progress", "Stopped", "simulate",
    "report_files", "play_seeds", "cost_text",
    # re-imported: where the command, the benchmarks and the changelog find them
    "BadInput", "load_inputs", "DEFAULT_IFC_START", "write_outputs", "write_makespans",
]


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
    disruption_cost: bool = True  # a disrupted case's floors also played without (measures_cost)
    fidelity: str = "pymunk"  # the floor: the paper's, or the event floor (training/fidelity.py)
    calibration: Path | None = None  # the event floor's (None: the case's, if any)
    seed_charts: bool = True  # each seed's Gantt charts and trajectories (with ``charts``)
    # who asks for lifts (``cmdp_pymunk.logistics.from_spec``; "case": the case's reorder point)
    logistics: str = "case"


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
