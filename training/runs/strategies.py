"""The run behind ``cmdp-evaluate`` (``training/commands/evaluate_strategies.py``): target
strategies x low levels x seeds played on a backend, the log a stopped run resumes from, the
summaries, the figures and the settings. The what-if (several cases or variants on the same
seeds) is ``whatif_run``'s. The command parses its options into ``EvaluateArgs`` and calls
``compare_strategies`` or ``whatif_run.compare_whatif``; what each file holds is the command's
documentation (``cmdp-evaluate --help``, docs/comparing.md).
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
from cmdp_pymunk.logistics import Learned, from_spec
from cmdp_pymunk.report import versions
from cmdp_pymunk.workcalendar import calendar_summary
from training.cli import calendar_of
from training.fidelity import Floor, resolve_floor
from training.runs.backends import WorkerLost, open_backend
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
from training.whatif import MONEY_FIELDS, money_summary, money_table, played_row

DEFAULT_STRATEGIES = ("priority", "nearest")  # CP-SAT (about 20 s on the built-in floor) on request


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
    # who asks for lifts (``cmdp_pymunk.logistics.from_spec``; "case": the case's reorder point)
    logistics: str = "case"

    @property
    def whatif(self) -> bool:
        """Several cases or variants compared on the same seeds (``whatif``)."""
        return len(self.cases) > 1 or bool(self.variants)

    @property
    def solves_cpsat(self) -> bool:
        """CP-SAT runs only when asked for: the ``cpsat`` strategy or ``--cpsat-bound``."""
        return self.cpsat_bound or "cpsat" in self.strategies



def write_tables(out: Path, name: str, rows: list[dict], fields: list[str],
                 summary: list[dict], table: str, time_use: list[dict]) -> None:
    """A comparison's tables, each whole: ``episodes.csv``, ``NAME.csv``/``.md``/``.json``
    (the summary) and ``time_use.csv`` (if any)."""
    write_atomic(out / "episodes.csv", csv_text(rows, fields))
    write_atomic(out / f"{name}.csv", csv_text(summary, list(summary[0])))
    write_atomic(out / f"{name}.md", table)
    write_atomic(out / f"{name}.json", json.dumps(summary, indent=1) + "\n")
    if time_use:
        write_atomic(out / "time_use.csv", csv_text(time_use, list(time_use[0])))

def episode_job(runner: EpisodeRunner, spec: str, navigator: str, seed: int,
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
           **resume_floor(run_floor(case, args)),
           # and who asks for lifts: a run resumes only with the same role (and model numbers)
           **resume_logistics(args.logistics)}
    if measures_cost(args, case):  # only then: runs written before it resume as they were
        out["disruption_cost"] = True
    return out


def resume_floor(floor: Floor) -> dict:
    """The floor as ``resume.json`` keeps it: the fidelity and the calibration's numbers
    (wherever its file is now)."""
    return {"fidelity": floor.fidelity, "calibration": floor.calibration.model_dump(mode="json")
            if floor.calibration is not None else None}


def resume_logistics(spec: str) -> dict:
    """The logistics as ``resume.json`` keeps it: the ``--logistics`` spec and, for a learned
    rule, the model's numbers (wherever its file is now; a refitted file is another role)."""
    role = from_spec(spec)
    out: dict = {"logistics": spec}
    if isinstance(role, Learned):
        model = json.loads(role.to_json())
        out["logistics_model"] = {k: model[k] for k in ("features", "weights", "bias", "shares")}
    return out


def run_floor(case, args: EvaluateArgs) -> Floor:
    """The floor of the run (``--fidelity``, ``--calibration``; ``training.fidelity``);
    ValueError naming the option and the fix."""
    return resolve_floor(case, args.case, args.fidelity, args.calibration,
                         {"--navigators": args.navigators})


def play_episodes(case, args: EvaluateArgs, run_specs: dict[str, str], pool=None,
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
                   *floor.runner_args, args.logistics)
    log_path = args.out / LOG
    with log_path.open("a" if done else "w") as log:
        if done:  # the earlier rows only (a cut last line is dropped)
            log.seek(0)
            log.truncate()
            log.writelines(json.dumps(r) + "\n" for r in done)
            log.flush()
        try:
            with nullcontext(pool) if pool is not None else \
                    open_backend(episode_job, runner_args, args.workers) as backend:
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


def logistics_label(spec: str) -> str:
    """For the console header: ``, logistics SPEC``, or nothing for the case's own."""
    return "" if spec == "case" else f", logistics {spec}"


class BadSetting(Exception):
    """A bad setting found after the arguments were parsed: exit 2 with this line."""


def compare_strategies(args: EvaluateArgs) -> int:
    """Every strategy x low level x seed (the module doc), resumed from ``args.out`` with
    ``args.resume``; returns the exit status (1 if an episode stalled, timed out or was lost).
    ``BadSetting`` or ``BackendError`` (exit 2) before any episode."""
    case, calendar, floor = _checked_inputs(args)
    run_specs = {s: s for s in args.strategies}
    done = resumable(case, args) if args.resume else []
    args.out.mkdir(parents=True, exist_ok=True)
    runner_args = (case, args.stall_s, args.max_time_s, args.deterministic, None,
                   *floor.runner_args, args.logistics)
    # Workers (and Ray) start before CP-SAT: an unreachable cluster fails before any work.
    with open_backend(episode_job, runner_args, args.workers, args.ray) as pool:
        lb = lower_bound(case)
        cpsat = _bounds_header(case, args, floor, lb)
        if "cpsat" in args.strategies:
            run_specs["cpsat"] = _cpsat_spec(case, args, cpsat)
        _check_on_workers(case, args, run_specs, pool)
        write_atomic(args.out / "resume.json", json.dumps(resume_settings(case, args)) + "\n")
        kept = _announce(case, args, pool, done)
        start = time.perf_counter()
        try:
            rows = play_episodes(case, args, run_specs, pool, done)
        except WorkerLost as err:
            print(f"cmdp-evaluate: {err}; the finished episodes are in {args.out / LOG}; "
                  "rerun with --resume to run the lost ones again", file=sys.stderr)
            return 1
        wall = time.perf_counter() - start
    ran = len(rows) - kept
    cpsat_dict = cpsat.as_dict() if cpsat else None
    rows, summary, fields, table, time_use = _results(case, args, floor, calendar, rows, lb,
                                                      cpsat_dict)
    settings = {**asdict(args), "workers": pool.workers, "backend": pool.label,
                "working_calendar": calendar_summary(calendar, None, None) if calendar else None,
                "case": case.case.name, "case_file": str(args.case) if args.case else "built-in",
                **floor.record(),
                "lower_bound": lb.as_dict(), "cpsat": cpsat_dict,
                "episodes": len(rows), "episodes_resumed": kept, "wall_s": round(wall, 1),
                "episodes_per_s": round(ran / wall, 3) if wall > 0 else None,
                "command": sys.argv, "versions": versions()}
    _write_results(case, args, rows, fields, summary, table, time_use, settings, lb, cpsat)
    print(table, end="")
    print(f"cmdp-evaluate: {ran} episodes in {wall:.0f} s "
          f"({ran / max(wall, 1e-9):.2f} episodes/s) -> {args.out}")
    return 1 if any(not r["finished"] for r in rows) else 0


def _checked_inputs(args: EvaluateArgs):
    """The case, its working calendar and the floor, every setting checked against them
    before anything is built or run (``BadSetting`` naming the fix)."""
    try:
        case = cmdp_pymunk.load_case(args.case)
        calendar = calendar_of(case, args)  # dates the finishes; the episodes run in seconds
        floor = run_floor(case, args)  # before anything is built or run
        from_spec(args.logistics, case=case)  # a role that misfits the case
        check_specs(case, [s for s in args.strategies if s != "cpsat"], args.navigators,
                    args.deterministic)
    except ValueError as err:  # CaseError is a ValueError
        raise BadSetting(str(err)) from None
    return case, calendar, floor


def _bounds_header(case, args: EvaluateArgs, floor: Floor, lb):
    """The CP-SAT solve if the run asks for it (its result, else None), and the run's first
    line: the case, the floor, the bounds; the uncalibrated floor's note."""
    cpsat = None
    if args.solves_cpsat:
        from agents.cpsat import solve

        why = "for the cpsat strategy" if "cpsat" in args.strategies else "(--cpsat-bound)"
        print(f"cmdp-evaluate: solving CP-SAT {why}, time limit {args.cpsat_s:g} s ...",
              flush=True)
        cpsat = solve(case, args.cpsat_s)
        print(f"cmdp-evaluate: case {case.case.name!r} on the {floor.label()}"
              f"{logistics_label(args.logistics)}: lower bound "
              f"{lb.lower_bound_s:,.0f} s; CP-SAT bound {cpsat.bound_s:,.0f} s "
              f"({'optimal' if cpsat.optimal else 'not proven optimal'}, best schedule "
              f"{cpsat.makespan_s or float('nan'):,.0f} s, {cpsat.wall_s:.1f} s)")
    else:
        print(f"cmdp-evaluate: case {case.case.name!r} on the {floor.label()}"
              f"{logistics_label(args.logistics)}: lower bound "
              f"{lb.lower_bound_s:,.0f} s (CP-SAT not solved: add the cpsat strategy or "
              "--cpsat-bound for its bound)")
    if floor.uncalibrated_note(args.case):
        print(f"cmdp-evaluate: {floor.uncalibrated_note(args.case)}", file=sys.stderr,
              flush=True)
    return cpsat


def _cpsat_spec(case, args: EvaluateArgs, cpsat) -> str:
    """The cpsat strategy's spec: the plan it replays (the kept one on ``--resume``)."""
    from agents.cpsat import save_plan

    plan = args.out / "cpsat_plan.json"
    if args.resume and plan.is_file():  # the kept episodes replayed this plan
        return f"cpsat:{plan}"
    try:
        return f"cpsat:{save_plan(plan, case, cpsat)}"
    except ValueError as err:
        raise BadSetting(str(err)) from None


def _check_on_workers(case, args: EvaluateArgs, run_specs: dict[str, str], pool) -> None:
    """Every strategy's files found by every worker, and each strategy able to play the case
    without its disruptions where the run measures what they cost (``BadSetting``)."""
    problems = [p for p in pool.check_each(check_worker, list(run_specs.values()),
                                           args.navigators, args.deterministic) if p]
    if problems:
        raise BadSetting(f"{problems[0]}; fix: put the file at the same path on every "
                         "node (a shared file system), docs/ray.md")
    if measures_cost(args, case):  # a strategy that cannot play the plain case fails
        from cmdp_pymunk.disruptions import undisrupted  # now, not in a worker

        try:
            check_specs(undisrupted(case), list(run_specs.values()), args.navigators,
                        args.deterministic)
        except ValueError as err:
            raise BadSetting(f"the case without its disruptions (what they cost): {err}; "
                             "fix: add --no-disruption-cost") from None


def _announce(case, args: EvaluateArgs, pool, done: list[dict]) -> int:
    """The run's second line (episodes, those kept from an earlier run, the backend) and the
    disruptions' note; returns the episodes kept."""
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
    return kept


def _results(case, args: EvaluateArgs, floor: Floor, calendar, rows: list[dict], lb,
             cpsat: dict | None):
    """The episodes' rows (dated), the summary per strategy, the log's fields, the markdown
    table and the time use; ``cpsat``: the CP-SAT result as data (None: not solved)."""
    # each strategy's entry says the floor it ran on (appended: older columns keep their places)
    summary = [{**e, "fidelity": floor.fidelity, "calibration": floor.source or "",
                "calibration_fingerprint": floor.calibration.fingerprint
                if floor.calibration is not None else ""}
               for e in summarize(rows, lb.lower_bound_s, cpsat["bound_s"] if cpsat else None)]
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
    table = markdown_table(summary, lb.lower_bound_s, cpsat)
    if args.logistics != "case":  # no table of another logistics may pass for the case's
        table = (f"Logistics {args.logistics} (who asks for lifts), not the case's reorder "
                 "point.\n\n" + table)
    if floor.fidelity == "event":  # no event-floor table may pass for the pymunk floor's
        table = f"On the {floor.label()}, not the pymunk floor.\n\n" + table
    if calendar is not None:
        table += "\n" + finish_dates_table(calendar, summary)
    table += "\n" + money_table(summary, case)
    if time_use:
        table += "\n" + time_use_table(time_use)
    return rows, summary, fields, table, time_use


def _write_results(case, args: EvaluateArgs, rows, fields, summary, table, time_use,
                   settings: dict, lb, cpsat) -> None:
    """The tables, the settings and the figures, a Ctrl-C held until all are written."""
    from cmdp_pymunk import interrupt

    interrupt.enter()
    try:
        write_tables(args.out, "summary", rows, fields, summary, table, time_use)
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


def resumable(case, args: EvaluateArgs) -> list[dict]:
    """The rows of an earlier run in ``args.out`` (``--resume``), if its settings match."""
    saved = args.out / "resume.json"
    if not saved.is_file():
        raise BadSetting(f"--resume: {saved} not found: no earlier run in {args.out}; fix: "
                         "drop --resume, or give the --out of the run to finish")
    before = json.loads(saved.read_text())
    before.setdefault("fidelity", "pymunk")  # written before --fidelity: the pymunk floor
    before.setdefault("calibration", None)
    before.setdefault("logistics", "case")  # written before --logistics: the case's own
    now = json.loads(json.dumps(resume_settings(case, args)))
    changed = sorted(k for k in now if before.get(k) != now[k])
    if changed:
        raise BadSetting(f"--resume: the run in {args.out} used other settings "
                         f"({', '.join(changed)}); fix: resume with the same ones, or start a "
                         "new --out")
    # rows of a run from before --fidelity: its resume.json matched, so they are pymunk rows
    return [{**r, "fidelity": r.get("fidelity", "pymunk")} for r in read_log(args.out / LOG)]
