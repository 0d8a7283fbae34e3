"""``cmdp-evaluate``: compare target strategies over many seeds (section 5.3, Figs. 12-14).

    cmdp-evaluate [--case FILE] [--seeds 0-19] [--strategies priority,nearest,ga:PATH,cpsat,M.zip]
                  [--navigators scripted,MODEL.zip] [--workers N] [--ray [ADDRESS]]
                  [--out DIR] [--resume] [--cpsat-bound] [--cpsat-s 20]
                  [--fidelity pymunk|event [--calibration PATH]]
                  [--logistics case|never|reorder:LIFTS|crane-idle|learned:PATH]

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
continues a run only on the floor and calibration it started on. ``--logistics SPEC`` (as in
``cmdp-simulate``: ``case``, the default, ``never``, ``reorder:LIFTS``, ``crane-idle``,
``learned:PATH``; docs/levers.md) says who asks for the next crane lift in every episode:
the header, ``settings.json`` (``logistics``), the first line of ``summary.md`` (when not
``case``) and ``resume.json`` say so, and ``--resume`` continues a run only with the same
role (and, for ``learned:PATH``, the same model numbers). Writes into DIR:

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

import sys
from pathlib import Path

import cmdp_pymunk
from cmdp_pymunk.interrupt import sigint_guard
from training.cli import (
    OneLineParser,
    add_calendar_options,
    add_logistics_option,
    add_ray_option,
    plain,
    positive_int,
    positive_seconds,
    seed_list,
    spec_list,
)
from training.fidelity import add_fidelity_options
from training.runs.backends import BackendError
from training.runs.strategies import (
    DEFAULT_STRATEGIES,
    LOG,
    BadSetting,
    EvaluateArgs,
    compare_strategies,
    read_log,
)
from training.runs.whatif_run import compare_whatif


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
    add_logistics_option(p)
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
                        cases, variants, a.logistics)


def main(argv: list[str] | None = None) -> int:
    """The command; Ctrl-C stops it with one line and exit status 130, keeping the finished
    episodes in DIR/episodes.jsonl."""
    args = parse_args(argv)
    try:
        with sigint_guard():
            if args.whatif:
                return compare_whatif(args)
            return compare_strategies(args)
    except KeyboardInterrupt:
        kept = len(read_log(args.out / LOG))
        print(f"\ncmdp-evaluate: interrupted; {kept} finished episode(s) kept in "
              f"{args.out / LOG}; to finish, rerun with --resume", file=sys.stderr)
        return 130
    except (BadSetting, BackendError) as err:
        print(f"cmdp-evaluate: {err}", file=sys.stderr)
        return 2


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
