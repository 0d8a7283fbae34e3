"""``cmdp-evaluate``: compare target strategies over many seeds (section 5.3, Figs. 12-14).

    cmdp-evaluate [--case FILE] [--seeds 0-19] [--strategies priority,nearest,ga:PATH,cpsat,M.zip]
                  [--navigators scripted,MODEL.zip] [--workers N] [--ray [ADDRESS]]
                  [--out DIR] [--resume] [--cpsat-bound] [--cpsat-s 20]
                  [--fidelity pymunk|event [--calibration PATH]]

Runs every seed x strategy x low level (the evaluators of ``cmdp-simulate --evaluator``,
including a stage-2 model ``.zip``; the low levels of ``--navigator``) in worker processes,
or on Ray actors with ``--ray`` (a Ray started here) or ``--ray ADDRESS`` (a cluster;
docs/ray.md); the same seeds give the same episodes whatever the backend and the number of
workers. CP-SAT is solved only when asked for: the ``cpsat`` strategy (solved once here,
``--cpsat-s`` seconds, and its plan, saved as ``cpsat_plan.json``, replayed) or
``--cpsat-bound`` (its bound only); it is announced with its time limit before it runs.
Without it the bound columns use the cheap lower bound (``cmdp_pymunk.bounds``) alone and
the outputs say so. ``--fidelity event`` plays every episode on the event floor (fast,
calibrated on the pymunk floor, stage 2 without a low level: scripted navigators only;
``--calibration PATH``, as in ``cmdp-simulate``; docs/event-floor.md): the header, the first
line of ``summary.md``, each summary entry (``fidelity``, ``calibration``,
``calibration_fingerprint``), each episode row and ``settings.json`` say so, and ``--resume``
continues a run only on the floor and calibration it started on. Writes into DIR:

- ``episodes.jsonl``: each episode's row as soon as it finished, in the order they finish,
  with ``task_end_times_s`` (when each task ended, seconds): a stopped run (Ctrl-C, a lost
  worker) keeps them, and ``--resume`` runs only the others (with the same settings and the
  saved CP-SAT plan);
- ``episodes.csv``: one row per episode: makespan, reaching steps, idle steps by cause (with
  the crew-seconds each kind of disruption kept crews from working), crane waits, reach
  rate, whether it stalled or timed out (and why), wall seconds;
- ``summary.md``, ``summary.csv`` and ``summary.json``: per strategy and low level, the mean
  makespan with its 95 % interval, its P50/P80/P90 (the makespans 50, 80 and 90 % of the
  finished episodes stay within), over the lower bound and over CP-SAT's bound (empty when
  CP-SAT was not solved), the paired difference to the priority heuristic on the same seeds
  (95 % interval) and the ratio of means, reaching steps, idle steps by cause, crane waits;
  stalled and timed-out episodes are counted and listed;
- ``fig12_makespan.png``, ``fig13_reaching_steps.png``, ``fig14_idle_task_area.png``: box
  and strip plots per strategy with the mean, its 95 % interval and (Fig. 12) the bounds;
  with ``--per-seed`` the paper's lines over the seeds (``media/comparison.py``);
- ``makespan_histogram.png`` (one panel per strategy, its P50/P80/P90 marked) and
  ``s_curve.png`` (tasks ended over time, one colour per strategy: the median over the seeds
  and the 10-90 % band), ``media/episodes.py``;
- on a case with disruptions (a ``[disruptions]`` table, e.g. ``--case
  cmdp_pymunk/cases/precast_floor_disrupted.toml``; docs/disruptions.md): in each episode's
  row, how many of each kind struck and their downtime (``crane_breakdown_count``,
  ``crane_breakdown_downtime_s``, ... ``weather_downtime_s``) and what they cost: the makespan
  of the same seed, strategy and low level on the case without its disruptions
  (``undisrupted_makespan_s``; every task meets the same pace, so the difference is the
  disruptions' alone), ``disruption_delay_s`` and ``disruption_delay_pct``; in the summaries,
  per strategy, the mean delay with its 95 % interval. Each such episode is played twice in
  its worker; ``--no-disruption-cost`` plays it once (the counts stay);
- ``settings.json``: the arguments, seeds, bounds, CP-SAT's answer (null when not solved),
  versions and the command; ``resume.json``, what ``--resume`` checks; with the ``cpsat``
  strategy ``cpsat_plan.json``, the plan replayed.

A what-if (docs/levers.md): ``--case`` given several times, or ``--variant NAME=CHANGES``
(repeatable, e.g. ``more_rc=crews.RC+1``; ``cmdp_pymunk.cases.levers``), plays every case and
variant on the same seeds and writes ``whatif.md``, ``whatif.csv``, ``whatif.json`` (paired
differences of makespan and cost against the first, P50/P80, time use per crew type),
``episodes.jsonl``, ``episodes.csv``, ``time_use.csv``, ``variants/NAME.toml`` and
``settings.json`` (``training.whatif``). Every run costs its episodes (``cmdp_pymunk.cost``:
``cost`` in the rows, a "Cost" table in ``summary.md``).

``resume.json`` and ``cpsat_plan.json`` are written before the first episode; ``episodes.csv``,
the summaries, the figures and ``settings.json`` at the end, each atomically: a stopped run
leaves none of them half-written. Exit status 1 if any episode stalled, timed out or was lost
with its worker, 2 for bad arguments, a bad case or a Ray that cannot run the episodes (before
any episode), 130 on Ctrl-C.
"""

from __future__ import annotations

import json
import sys
import time
from contextlib import contextmanager, nullcontext
from dataclasses import asdict, dataclass
from pathlib import Path

import cmdp_pymunk
from cmdp_pymunk.bounds import lower_bound
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.interrupt import sigint_guard
from cmdp_pymunk.rollout import versions
from cmdp_pymunk.workcalendar import calendar_summary
from training.cli import (
    OneLineParser,
    add_calendar_options,
    add_ray_option,
    calendar_of,
    plain,
    positive_int,
    positive_seconds,
)
from training.fidelity import Floor, add_fidelity_options, resolve_floor
from training.runs.backends import BackendError, WorkerLost, open_backend
from training.runs.paired import (
    csv_text,
    markdown_table,
    summarize,
    time_use_summary,
    time_use_table,
)
from training.runs.runner import (
    COST_FIELDS,
    ROW_FIELDS,
    SEED_BOUND_FIELDS,
    STRUCK_FIELDS,
    EpisodeRunner,
    check_worker,
    cost_fields,
)
from training.runs.runner import check_specs as check_episode_specs
from training.whatif import MONEY_FIELDS, cost_note, money_summary, money_table, played_row

DEFAULT_STRATEGIES = ("priority", "nearest")  # CP-SAT (about 20 s on the built-in floor) on request


def seed_list(text: str) -> list[int]:
    """``0-19``, ``3,5,8`` or ``0-9,100-104``: whole numbers, ranges inclusive."""
    import argparse

    seeds: list[int] = []
    try:
        for part in text.split(","):
            a, sep, b = part.strip().partition("-")
            lo, hi = int(a), int(b) if sep else int(a)
            if lo < 0 or hi < lo:
                raise ValueError
            seeds.extend(range(lo, hi + 1))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a list of seeds; fix: give e.g. "
                                         "0-19 or 0,3,5 (whole numbers >= 0)") from None
    if len(set(seeds)) != len(seeds):
        raise argparse.ArgumentTypeError(f"{text!r} names a seed twice")
    return seeds


def spec_list(text: str) -> list[str]:
    return [s.strip() for s in text.split(",") if s.strip()]


@dataclass(frozen=True)
class EvaluateArgs:
    case: Path | None
    seeds: list[int]
    strategies: list[str]
    navigators: list[str]
    workers: int | None  # None: every core (local), every CPU of the cluster (Ray)
    out: Path
    stall_s: float
    max_time_s: float | None
    cpsat_s: float
    deterministic: bool
    figures: bool
    progress: bool
    ray: str | None = None  # None: worker processes here; "local": a Ray started here
    resume: bool = False
    cpsat_bound: bool = False  # solve CP-SAT for its bound even without the cpsat strategy
    per_seed: bool = False  # Figs. 12-14 as the paper's lines over the seeds
    disruption_cost: bool = True  # a disrupted case's episodes also played without (doc)
    fidelity: str = "pymunk"  # the floor: the paper's, or the event floor (training/fidelity.py)
    calibration: Path | None = None  # the event floor's (None: the case's, if any)
    # the working calendar that dates the finishes (None: the case's, or none)
    calendar: Path | None = None
    start: str | None = None
    working_hours: str | None = None
    working_days: str | None = None
    holidays: str | None = None
    # a what-if (docs/levers.md): every --case (the first is ``case``) and --variant NAME=CHANGES
    cases: tuple[Path, ...] = ()
    variants: tuple[str, ...] = ()

    @property
    def whatif(self) -> bool:
        """Several cases or variants compared on the same seeds (``whatif``)."""
        return len(self.cases) > 1 or bool(self.variants)

    @property
    def solves_cpsat(self) -> bool:
        """CP-SAT runs only when asked for: the ``cpsat`` strategy or ``--cpsat-bound``."""
        return self.cpsat_bound or "cpsat" in self.strategies


def parse_args(argv: list[str] | None = None) -> EvaluateArgs:
    p = OneLineParser(prog="cmdp-evaluate", description=plain(__doc__), epilog=(
        "Writes into --out: episodes.jsonl (each episode as it ends, with its task end "
        "times), episodes.csv, summary.md, summary.csv, summary.json (mean with 95 % "
        "interval, P50/P80/P90, paired difference to priority), fig12_makespan.png, "
        "fig13_reaching_steps.png, fig14_idle_task_area.png, makespan_histogram.png, "
        "s_curve.png, settings.json, resume.json (cpsat: cpsat_plan.json). Disruptions (crane "
        "breakdowns, late deliveries, absences, weather stops) strike with a case that has a "
        "[disruptions] table, e.g. --case cmdp_pymunk/cases/precast_floor_disrupted.toml "
        "(docs/disruptions.md): each row then counts them, and their cost against the same "
        "seed undisrupted is in the rows and the summaries (--no-disruption-cost skips it). "
        "Exit status 1 if an episode stalled, timed out or was lost, 2 for bad options, 130 "
        "on Ctrl-C. docs/comparing.md"))
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--case", type=Path, action="append", default=None,
                   help="case file (default: built-in); give it several times to compare "
                        "cases on the same seeds (a what-if: whatif.md, docs/levers.md)")
    p.add_argument("--variant", action="append", default=None, metavar="NAME=CHANGES",
                   help="a variant of the (first) case compared with it on the same seeds, "
                        "e.g. more_rc=crews.RC+1 or early=rebars.reorder_at=0.5,crews.FC-1; "
                        "repeatable (a what-if: whatif.md, docs/levers.md)")
    p.add_argument("--seeds", type=seed_list, default=list(range(20)),
                   help="seeds, e.g. 0-19 (default) or 0,3,5")
    p.add_argument("--strategies", type=spec_list, default=list(DEFAULT_STRATEGIES),
                   help="comma-separated evaluators: priority, nearest, ga:PATH, cpsat (solves "
                        "CP-SAT here, --cpsat-s), cpsat:PATH, student:PATH, lookahead[:...], "
                        "replan[:...], a stage-2 model .zip (default: priority,nearest)")
    p.add_argument("--navigators", type=spec_list, default=["scripted"],
                   help="comma-separated low levels: scripted, a stage-1 model .zip "
                        "(default: scripted)")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="worker processes, or Ray actors with --ray (default: every core; "
                        "with --ray ADDRESS, every CPU of the cluster)")
    add_ray_option(p)
    p.add_argument("--out", type=Path, default=Path("out/evaluate"),
                   help="the folder to write into (default out/evaluate)")
    p.add_argument("--resume", action="store_true",
                   help="keep the episodes in DIR/episodes.jsonl and run only the others")
    p.add_argument("--stall-s", type=positive_seconds, default=3600.0,
                   help="an episode in which no task moves on for this many simulated seconds "
                        "stalls (default 3600)")
    p.add_argument("--max-time-s", type=positive_seconds, default=None,
                   help="stop an episode at this simulated time (default: the case's limit)")
    p.add_argument("--cpsat-bound", action="store_true",
                   help="solve CP-SAT for its schedule bound even without the cpsat strategy "
                        "(the x CP-SAT bound column; --cpsat-s seconds)")
    p.add_argument("--cpsat-s", type=positive_seconds, default=20.0,
                   help="CP-SAT's time limit for the bound and the plan, when the cpsat "
                        "strategy or --cpsat-bound asks for it (default 20)")
    p.add_argument("--deterministic", action="store_true",
                   help="model navigators take their argmax action instead of sampling")
    p.add_argument("--no-figures", action="store_true",
                   help="write no figures (Figs. 12-14, the histogram, the S-curve)")
    p.add_argument("--per-seed", action="store_true",
                   help="Figs. 12-14 as the paper's lines over the seeds instead of box and "
                        "strip plots per strategy")
    p.add_argument("--no-disruption-cost", action="store_true",
                   help="on a case with disruptions, do not also play each episode without "
                        "them (what they cost: undisrupted_makespan_s, disruption_delay_s; "
                        "measuring it doubles the work). A case without disruptions is played "
                        "once either way")
    add_fidelity_options(p)
    add_calendar_options(p, "episodes.csv, summary.md, summary.csv and summary.json (each "
                         "finish, and the mean and P50/P80/P90 finishes per strategy)")
    p.add_argument("--no-progress", action="store_true", help="show no progress bar")
    a = p.parse_args(argv)
    if not a.strategies or not a.navigators:
        p.error("--strategies and --navigators need at least one name each")
    for name, specs in (("--strategies", a.strategies), ("--navigators", a.navigators)):
        if len(set(specs)) != len(specs):
            p.error(f"{name} names one twice")
    cases, variants = tuple(a.case or ()), tuple(a.variant or ())
    if len(set(cases)) != len(cases):
        p.error("--case names one file twice")
    if len(cases) > 1 or variants:  # a what-if: what it cannot do, before anything runs
        for flag, given in (("--resume", a.resume), ("--cpsat-bound", a.cpsat_bound),
                            ("the cpsat strategy", "cpsat" in a.strategies),
                            ("--calendar and its options", any(
                                (a.calendar, a.start, a.working_hours, a.working_days,
                                 a.holidays)))):
            if given:
                p.error(f"{flag} does not go with a what-if (several --case or --variant); "
                        "fix: run it on one case without --variant")
    return EvaluateArgs(cases[0] if cases else None, a.seeds, a.strategies, a.navigators,
                        a.workers, a.out,
                        a.stall_s, a.max_time_s, a.cpsat_s, a.deterministic,
                        not a.no_figures, not a.no_progress, a.ray, a.resume, a.cpsat_bound,
                        a.per_seed, not a.no_disruption_cost, a.fidelity, a.calibration,
                        a.calendar, a.start, a.working_hours, a.working_days, a.holidays,
                        cases, variants)


def _episode_job(runner: EpisodeRunner, spec: str, navigator: str, seed: int,
                 cost: bool = False) -> dict:
    """One episode's row; ``cost``: the same seed also on the case without its disruptions,
    in the same worker, for what they cost (``cost_fields``)."""
    row = played_row(runner, spec, navigator, seed)
    undisrupted = runner.run(spec, navigator, seed, undisrupted=True) if cost else None
    return {**row, **cost_fields(row, undisrupted)}


def measures_cost(args: EvaluateArgs, case) -> bool:
    """Whether each episode is also played without the case's disruptions (module doc)."""
    return args.disruption_cost and bool(case.disruptions)


def check_specs(case, strategies: list[str], navigators: list[str],
                deterministic: bool) -> None:
    """``training.runs.runner.check_specs``, before any episode, its errors naming this command's
    options."""
    for spec in strategies:
        with _named_as("--evaluator", "--strategies"):
            check_episode_specs(case, [spec], [], deterministic)
    for spec in navigators:
        with _named_as("--navigator", "--navigators"):
            check_episode_specs(case, [], [spec], deterministic)


@contextmanager
def _named_as(option: str, ours: str):
    """A spec's error names ``cmdp-simulate``'s option (``agents.specs``): name ours."""
    try:
        yield
    except ValueError as err:
        text = str(err)
        if text.startswith(option + " "):
            raise type(err)(ours + text[len(option):]) from None
        raise


LOG = "episodes.jsonl"


def episode_jobs(args: EvaluateArgs) -> list[tuple[str, str, int]]:
    """Every (strategy, navigator, seed), navigator first, then strategy, then seed."""
    return [(s, n, seed) for n in args.navigators for s in args.strategies for seed in args.seeds]


def read_log(path: Path) -> list[dict]:
    """The rows of ``episodes.jsonl``; a last line cut short by a killed run is dropped."""
    rows = []
    if path.is_file():
        for line in path.read_text().splitlines():
            try:
                rows.append(json.loads(line))
            except json.JSONDecodeError:
                break
    return rows


def resume_settings(case, args: EvaluateArgs) -> dict:
    """What must not change between a run and its ``--resume``."""
    out = {"case": case.model_dump(mode="json"),
           **{k: getattr(args, k) for k in ("stall_s", "max_time_s", "deterministic")},
           # the floor: a run on the event floor resumes only on it, with the same numbers
           **resume_floor(run_floor(case, args))}
    if measures_cost(args, case):  # only then: runs written before it resume as they were
        out["disruption_cost"] = True
    return out


def resume_floor(floor: Floor) -> dict:
    """The floor as ``resume.json`` keeps it: the fidelity and the calibration's numbers
    (wherever its file is now)."""
    return {"fidelity": floor.fidelity, "calibration": floor.calibration.model_dump(mode="json")
            if floor.calibration is not None else None}


def run_floor(case, args: EvaluateArgs) -> Floor:
    """The floor of the run (``--fidelity``, ``--calibration``; ``training.fidelity``);
    ValueError naming the option and the fix."""
    return resolve_floor(case, args.case, args.fidelity, args.calibration,
                         {"--navigators": args.navigators})


def evaluate(case, args: EvaluateArgs, run_specs: dict[str, str], pool=None,
             done: list[dict] | None = None) -> list[dict]:
    """Every (navigator, strategy, seed) episode, in that order; ``run_specs`` maps a strategy
    to the spec the workers load (``cpsat`` -> its saved plan). ``pool``: an open backend
    (default: ``args.workers`` local processes). ``done``: the rows of an earlier run in the
    same folder (``--resume``): those this run asks for are not run again, and all of them
    stay in the log. Each new row is appended to ``args.out/episodes.jsonl`` as it arrives; a lost
    worker's episodes raise ``WorkerLost`` after all the others were written."""
    from tqdm import tqdm

    labels = episode_jobs(args)
    rows = {(r["strategy"], r["navigator"], r["seed"]): r for r in done or []}
    todo = [k for k in labels if k not in rows]
    cost = measures_cost(args, case)
    jobs = [(run_specs[s], n, seed, cost) for s, n, seed in todo]
    bar = tqdm(total=len(labels), initial=len(labels) - len(todo), unit="episode",
               disable=not args.progress, mininterval=1.0, desc="cmdp-evaluate")
    floor = run_floor(case, args)
    runner_args = (case, args.stall_s, args.max_time_s, args.deterministic, None,
                   *floor.runner_args)
    log_path = args.out / LOG
    with log_path.open("a" if done else "w") as log:
        if done:  # the earlier rows only (a cut last line is dropped)
            log.seek(0)
            log.truncate()
            log.writelines(json.dumps(r) + "\n" for r in done)
            log.flush()
        try:
            with nullcontext(pool) if pool is not None else \
                    open_backend(_episode_job, runner_args, args.workers) as backend:
                for i, row in backend.as_completed(jobs):
                    strategy, navigator, seed = todo[i]
                    row = {"strategy": strategy, "navigator": navigator, "seed": seed,
                           "fidelity": floor.fidelity, **row}
                    log.write(json.dumps(row) + "\n")
                    log.flush()
                    rows[todo[i]] = row
                    bar.update(1)
                    bar.set_postfix_str(f"{strategy} seed {seed}", refresh=False)
        finally:
            bar.close()
    return [rows[k] for k in labels]


class _Stop(Exception):
    """A bad setting found after the arguments were parsed: exit 2 with this line."""


def main(argv: list[str] | None = None) -> int:
    """The command; Ctrl-C stops it with one line and exit status 130, keeping the finished
    episodes in DIR/episodes.jsonl."""
    args = parse_args(argv)
    try:
        with sigint_guard():
            if args.whatif:
                return _whatif_main(args)
            return _main(args)
    except KeyboardInterrupt:
        kept = len(read_log(args.out / LOG))
        print(f"\ncmdp-evaluate: interrupted; {kept} finished episode(s) kept in "
              f"{args.out / LOG}; to finish, rerun with --resume", file=sys.stderr)
        return 130
    except (_Stop, BackendError) as err:
        print(f"cmdp-evaluate: {err}", file=sys.stderr)
        return 2


def _main(args: EvaluateArgs) -> int:
    from cmdp_pymunk import interrupt

    try:
        case = cmdp_pymunk.load_case(args.case)
        calendar = calendar_of(case, args)  # dates the finishes; the episodes run in seconds
        floor = run_floor(case, args)  # before anything is built or run
        check_specs(case, [s for s in args.strategies if s != "cpsat"], args.navigators,
                    args.deterministic)
    except ValueError as err:  # CaseError is a ValueError
        raise _Stop(str(err)) from None
    run_specs = {s: s for s in args.strategies}
    done = _resumable(case, args) if args.resume else []
    args.out.mkdir(parents=True, exist_ok=True)
    runner_args = (case, args.stall_s, args.max_time_s, args.deterministic, None,
                   *floor.runner_args)
    # Workers (and Ray) start before CP-SAT: an unreachable cluster fails before any work.
    with open_backend(_episode_job, runner_args, args.workers, args.ray) as pool:
        lb = lower_bound(case)
        cpsat = None
        if args.solves_cpsat:
            from agents.cpsat import save_plan, solve

            why = "for the cpsat strategy" if "cpsat" in args.strategies else "(--cpsat-bound)"
            print(f"cmdp-evaluate: solving CP-SAT {why}, time limit {args.cpsat_s:g} s ...",
                  flush=True)
            cpsat = solve(case, args.cpsat_s)
            print(f"cmdp-evaluate: case {case.case.name!r} on the {floor.label()}: lower bound "
                  f"{lb.lower_bound_s:,.0f} s; CP-SAT bound {cpsat.bound_s:,.0f} s "
                  f"({'optimal' if cpsat.optimal else 'not proven optimal'}, best schedule "
                  f"{cpsat.makespan_s or float('nan'):,.0f} s, {cpsat.wall_s:.1f} s)")
        else:
            print(f"cmdp-evaluate: case {case.case.name!r} on the {floor.label()}: lower bound "
                  f"{lb.lower_bound_s:,.0f} s (CP-SAT not solved: add the cpsat strategy or "
                  "--cpsat-bound for its bound)")
        if floor.uncalibrated_note(args.case):
            print(f"cmdp-evaluate: {floor.uncalibrated_note(args.case)}", file=sys.stderr,
                  flush=True)
        if "cpsat" in args.strategies:
            plan = args.out / "cpsat_plan.json"
            if args.resume and plan.is_file():  # the kept episodes replayed this plan
                run_specs["cpsat"] = f"cpsat:{plan}"
            else:
                try:
                    run_specs["cpsat"] = f"cpsat:{save_plan(plan, case, cpsat)}"
                except ValueError as err:
                    raise _Stop(str(err)) from None
        problems = [p for p in pool.check_each(check_worker, list(run_specs.values()),
                                               args.navigators, args.deterministic) if p]
        if problems:
            raise _Stop(f"{problems[0]}; fix: put the file at the same path on every node "
                        "(a shared file system), docs/ray.md")
        if measures_cost(args, case):  # a strategy that cannot play the plain case fails
            from cmdp_pymunk.disruptions import undisrupted  # now, not in a worker

            try:
                check_specs(undisrupted(case), list(run_specs.values()), args.navigators,
                            args.deterministic)
            except ValueError as err:
                raise _Stop(f"the case without its disruptions (what they cost): {err}; fix: "
                            "add --no-disruption-cost") from None
        write_atomic(args.out / "resume.json", json.dumps(resume_settings(case, args)) + "\n")
        n = len(args.seeds) * len(args.strategies) * len(args.navigators)
        wanted = set(episode_jobs(args))
        kept = sum((r["strategy"], r["navigator"], r["seed"]) in wanted for r in done)
        print(f"cmdp-evaluate: {n} episodes ({len(args.strategies)} strategies x "
              f"{len(args.navigators)} low level(s) x {len(args.seeds)} seeds"
              + (f", {kept} kept from the earlier run" if kept else "")
              + f"), {pool.label}", flush=True)
        if measures_cost(args, case):
            print("cmdp-evaluate: the case has disruptions: each episode is also played "
                  "without them, for what they cost (--no-disruption-cost to skip)", flush=True)
        start = time.perf_counter()
        try:
            rows = evaluate(case, args, run_specs, pool, done)
        except WorkerLost as err:
            print(f"cmdp-evaluate: {err}; the finished episodes are in {args.out / LOG}; "
                  "rerun with --resume to run the lost ones again", file=sys.stderr)
            return 1
        wall = time.perf_counter() - start
    ran = len(rows) - kept
    cpsat_dict = cpsat.as_dict() if cpsat else None
    # each strategy's entry says the floor it ran on (appended: older columns keep their places)
    summary = [{**e, "fidelity": floor.fidelity, "calibration": floor.source or "",
                "calibration_fingerprint": floor.calibration.fingerprint
                if floor.calibration is not None else ""}
               for e in summarize(rows, lb.lower_bound_s, cpsat.bound_s if cpsat else None)]
    fields = ["strategy", "navigator", "seed", *ROW_FIELDS, *STRUCK_FIELDS, *COST_FIELDS,
              *SEED_BOUND_FIELDS, "fidelity"]
    if calendar is not None:  # appended: older columns keep their places
        rows, summary = date_finishes(calendar, rows, summary)
        fields.append("finish")
    fields += MONEY_FIELDS  # appended too
    summary = [{**e, **money_summary([r for r in rows if (r["strategy"], r["navigator"])
                                      == (e["strategy"], e["navigator"])], rows, e)}
               for e in summary]
    time_use = time_use_summary(rows)
    table = markdown_table(summary, lb.lower_bound_s, cpsat_dict)
    if floor.fidelity == "event":  # no event-floor table may pass for the pymunk floor's
        table = f"On the {floor.label()}, not the pymunk floor.\n\n" + table
    if calendar is not None:
        table += "\n" + finish_dates_table(calendar, summary)
    table += "\n" + money_table(summary, case)
    if time_use:
        table += "\n" + time_use_table(time_use)
    settings = {**asdict(args), "workers": pool.workers, "backend": pool.label,
                "working_calendar": calendar_summary(calendar, None, None) if calendar else None,
                "case": case.case.name, "case_file": str(args.case) if args.case else "built-in",
                **floor.record(),
                "lower_bound": lb.as_dict(), "cpsat": cpsat_dict, "episodes": len(rows),
                "episodes_resumed": kept, "wall_s": round(wall, 1),
                "episodes_per_s": round(ran / wall, 3) if wall > 0 else None,
                "command": sys.argv, "versions": versions()}
    # A Ctrl-C while the results are written is held until all of them are.
    interrupt.enter()
    try:
        write_atomic(args.out / "episodes.csv", csv_text(rows, fields))
        write_atomic(args.out / "summary.csv", csv_text(summary, list(summary[0])))
        write_atomic(args.out / "summary.md", table)
        write_atomic(args.out / "summary.json", json.dumps(summary, indent=1) + "\n")
        if time_use:
            write_atomic(args.out / "time_use.csv", csv_text(time_use, list(time_use[0])))
        write_atomic(args.out / "settings.json",
                     json.dumps(settings, indent=2, default=str) + "\n")
        if args.figures:
            from media.comparison import draw_comparison
            from media.episodes import draw_strategy_episodes

            draw_comparison(rows, args.out, summary, lb.lower_bound_s,
                            cpsat.bound_s if cpsat else None, args.per_seed)
            draw_strategy_episodes(args.out, rows, summary, len(case.tasks), lb.lower_bound_s)
            if time_use:
                from media.comparison import draw_time_use

                draw_time_use(time_use, args.out / "time_use.png")
    finally:
        interrupt.leave()
    print(table, end="")
    print(f"cmdp-evaluate: {ran} episodes in {wall:.0f} s "
          f"({ran / max(wall, 1e-9):.2f} episodes/s) -> {args.out}")
    return 1 if any(not r["finished"] for r in rows) else 0


def whatif_entries(args: EvaluateArgs) -> list:
    """The cases and variants of a what-if (``training.whatif.Entry``), the base first, each
    validated and with its floor, before anything runs; ValueError (a ``CaseError`` for a bad
    case or variant) naming the option, the entry and the fix. A variant runs on its base's
    floor: on the event floor, with the base case's calibration (crew-type numbers fitted on
    the base floor; the output says so)."""
    from cmdp_pymunk.cases.levers import make_variant, parse_variant_option
    from training.whatif import Entry

    paths = list(args.cases) or [None]
    entries: list[Entry] = []
    for i, path in enumerate(paths):
        case = cmdp_pymunk.load_case(path)
        floor = resolve_floor(case, path, args.fidelity, args.calibration if i == 0 else None,
                              {"--navigators": args.navigators})
        name = case.case.name
        if any(e.name == name for e in entries):
            name = Path(path).stem if path is not None else "built-in"
        entries.append(Entry(name, "", case, str(path) if path else "built-in", floor))
    base = entries[0]
    for text in args.variants:
        name, changes = parse_variant_option(text)
        if any(e.name == name for e in entries):
            raise ValueError(f"--variant {text!r}: the name {name!r} is taken; fix: give each "
                             "case and variant its own name")
        variant = make_variant(base.case, changes, name, source=f"--variant {name}")
        entries.append(Entry(name, variant.label, variant.case, f"--variant {text}",
                             base.floor))
    return entries


def _whatif_main(args: EvaluateArgs) -> int:
    """The what-if (``training.whatif``): every case and variant x strategy x low level x
    seed; writes episodes.jsonl, episodes.csv, whatif.md, whatif.csv, whatif.json,
    time_use.csv, variants/NAME.toml (each variant as a case file) and settings.json."""
    from tqdm import tqdm

    from cmdp_pymunk import interrupt
    from cmdp_pymunk.cases.levers import variant_toml
    from training.whatif import PAIRING_NOTE, whatif_job, whatif_summary, whatif_table

    try:
        entries = whatif_entries(args)
        for e in entries:
            check_specs(e.case, args.strategies, args.navigators, args.deterministic)
    except ValueError as err:  # CaseError is a ValueError
        raise _Stop(str(err)) from None
    args.out.mkdir(parents=True, exist_ok=True)
    tail = (args.stall_s, args.max_time_s, args.deterministic, None)
    labels = [(e, s, n, seed) for e in entries for n in args.navigators
              for s in args.strategies for seed in args.seeds]
    jobs = [(e.name, e.case.model_dump(mode="json"), (*tail, *e.floor.runner_args), s, n,
             seed) for e, s, n, seed in labels]
    print(f"cmdp-evaluate: what-if of {len(entries)} cases and variants against "
          f"{entries[0].name!r} on the {entries[0].floor.label()}: {len(jobs)} episodes "
          f"({len(args.strategies)} strategies x {len(args.navigators)} low level(s) x "
          f"{len(args.seeds)} seeds each)", flush=True)
    note = entries[0].floor.uncalibrated_note(args.case)
    if note:
        print(f"cmdp-evaluate: {note}", file=sys.stderr, flush=True)
    rows: list[dict | None] = [None] * len(jobs)
    start = time.perf_counter()
    bar = tqdm(total=len(jobs), unit="episode", disable=not args.progress, mininterval=1.0,
               desc="cmdp-evaluate")
    try:
        with (args.out / LOG).open("w") as log, \
                open_backend(whatif_job, None, args.workers, args.ray) as pool:
            for i, row in pool.as_completed(jobs):
                e, strategy, navigator, seed = labels[i]
                rows[i] = {"variant": e.name, "strategy": strategy, "navigator": navigator,
                           "seed": seed, "fidelity": e.floor.fidelity, **row}
                log.write(json.dumps(rows[i]) + "\n")
                log.flush()
                bar.update(1)
    except WorkerLost as err:
        print(f"cmdp-evaluate: {err}; the finished episodes are in {args.out / LOG}",
              file=sys.stderr)
        return 1
    finally:
        bar.close()
    wall = time.perf_counter() - start
    summary = whatif_summary(rows, entries)
    notes = [cost_note(entries[0].case)]
    if any(e.changes and e.floor.fidelity == "event" for e in entries):
        notes.append(f"On the {entries[0].floor.label()}, not the pymunk floor; each variant "
                     "runs on its base's calibration (crew-type numbers fitted on the base "
                     "floor).")
    time_use = time_use_summary([{**r, "strategy": f"{r['variant']} / {r['strategy']}"}
                                 for r in rows])
    table = whatif_table(summary, entries, notes)
    if time_use:
        table += "\n" + time_use_table(time_use)
    fields = ["variant", "strategy", "navigator", "seed", *ROW_FIELDS, *SEED_BOUND_FIELDS,
              "fidelity", *MONEY_FIELDS]
    settings = {**asdict(args), "backend": pool.label, "episodes": len(rows),
                "entries": [{"name": e.name, "changes": e.changes, "source": e.source,
                             "case": e.case.case.name, **e.floor.record()} for e in entries],
                "pairing": PAIRING_NOTE, "wall_s": round(wall, 1), "command": sys.argv,
                "versions": versions()}
    interrupt.enter()  # a Ctrl-C while the results are written is held until all are
    try:
        write_atomic(args.out / "episodes.csv", csv_text(rows, fields))
        write_atomic(args.out / "whatif.csv", csv_text(summary, list(summary[0])))
        write_atomic(args.out / "whatif.md", table)
        write_atomic(args.out / "whatif.json", json.dumps(summary, indent=1) + "\n")
        if time_use:
            write_atomic(args.out / "time_use.csv", csv_text(time_use, list(time_use[0])))
        for e in entries:
            if e.changes:
                (args.out / "variants").mkdir(exist_ok=True)
                write_atomic(args.out / "variants" / f"{e.name}.toml", variant_toml(
                    e.case, f"Variant {e.name!r} of {entries[0].name!r}: {e.changes}\n"
                    f"(cmdp-evaluate {e.source}; docs/levers.md)"))
        write_atomic(args.out / "settings.json",
                     json.dumps(settings, indent=2, default=str) + "\n")
    finally:
        interrupt.leave()
    print(table, end="")
    print(f"cmdp-evaluate: {len(rows)} episodes in {wall:.0f} s -> {args.out}")
    return 1 if any(not r["finished"] for r in rows) else 0


FINISHES = ("mean", "p50", "p80", "p90")  # the makespans each strategy's finish dates date


def date_finishes(calendar, rows: list[dict], summary: list[dict]) -> tuple[list, list]:
    """The rows with the calendar date of each finish (``finish``, empty for an unfinished
    episode) and the summary entries with ``finish_mean``, ``finish_p50``, ``finish_p80``,
    ``finish_p90``: simulated seconds as working time from the calendar's second 0."""
    from cmdp_pymunk.workcalendar import calendar_datetime, finish_dates, iso

    rows = [{**r, "finish": iso(calendar_datetime(calendar, r["makespan_s"]))
             if r["finished"] else ""} for r in rows]
    summary = [{**e, **{f"finish_{k}": v for k, v in finish_dates(calendar, {
        "mean": e["makespan_mean_s"], **{k: e.get(f"makespan_{k}_s") for k in FINISHES[1:]}
    }).items() if k in FINISHES}} for e in summary]
    return rows, summary


def finish_dates_table(calendar, summary: list[dict]) -> str:
    """summary.md's finish dates: one row per strategy and low level."""
    from cmdp_pymunk.workcalendar import describe, first_working_moment, iso

    lines = [f"Finish dates: second 0 = {iso(first_working_moment(calendar))}, working time "
             f"{describe(calendar)}.", "",
             "| strategy | low level | mean finish | P50 | P80 | P90 |",
             "|---|---|---|---|---|---|"]
    lines += [f"| {e['strategy']} | {e['navigator']} | "
              + " | ".join((e[f"finish_{k}"] or "-").replace("T", " ") for k in FINISHES) + " |"
              for e in summary]
    return "\n".join(lines) + "\n"


def _resumable(case, args: EvaluateArgs) -> list[dict]:
    """The rows of an earlier run in ``args.out`` (``--resume``), if its settings match."""
    saved = args.out / "resume.json"
    if not saved.is_file():
        raise _Stop(f"--resume: {saved} not found: no earlier run in {args.out}; fix: drop "
                    "--resume, or give the --out of the run to finish")
    before = json.loads(saved.read_text())
    before.setdefault("fidelity", "pymunk")  # written before --fidelity: the pymunk floor
    before.setdefault("calibration", None)
    now = json.loads(json.dumps(resume_settings(case, args)))
    changed = sorted(k for k in now if before.get(k) != now[k])
    if changed:
        raise _Stop(f"--resume: the run in {args.out} used other settings ({', '.join(changed)}); "
                    "fix: resume with the same ones, or start a new --out")
    # rows of a run from before --fidelity: its resume.json matched, so they are pymunk rows
    return [{**r, "fidelity": r.get("fidelity", "pymunk")} for r in read_log(args.out / LOG)]


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
