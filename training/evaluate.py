"""``cmdp-evaluate``: compare target strategies over many seeds (section 5.3, Figs. 12-14).

    cmdp-evaluate [--case FILE] [--seeds 0-19] [--strategies priority,nearest,ga:PATH,cpsat,M.zip]
                  [--navigators scripted,MODEL.zip] [--workers N] [--out DIR] [--cpsat-s 20]

Runs every seed x strategy x low level (the evaluators of ``cmdp-simulate --evaluator``,
including a stage-2 model ``.zip``; the low levels of ``--navigator``) in worker processes;
the same seeds give the same episodes whatever the number of workers. ``cpsat`` is solved
once here (``--cpsat-s`` seconds) and its plan, saved as ``cpsat_plan.json``, is replayed.
Writes into DIR:

- ``episodes.csv``: one row per episode: makespan, reaching steps, idle steps by cause (with
  the crew-seconds each kind of disruption kept crews from working), crane waits, reach
  rate, whether it stalled or timed out (and why), wall seconds;
- ``summary.md`` and ``summary.csv``: per strategy and low level, the mean makespan with its
  95 % interval, its P80 (the makespan 80 % of the finished episodes stay within), over
  the lower bound and over CP-SAT's bound, the paired difference to the
  priority heuristic on the same seeds (95 % interval) and the ratio of means, reaching steps,
  idle steps by cause, crane waits; stalled and timed-out episodes are counted and listed;
- ``fig12_makespan.png``, ``fig13_reaching_steps.png``, ``fig14_idle_task_area.png``;
- ``settings.json``: the arguments, seeds, bounds, CP-SAT's answer, versions and the command.

Exit status 1 if any episode stalled or timed out, 2 for bad arguments or a bad case.
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import cmdp_pymunk
from agents.episodes import ROW_FIELDS, EpisodeRunner, Workers, default_workers, make_env
from agents.specs import make_evaluator, make_navigator
from cmdp_pymunk.bounds import lower_bound
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.rollout import versions
from training.cli import OneLineParser, positive_int, positive_seconds
from training.comparison import csv_text, markdown_table, summarize


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
    workers: int
    out: Path
    stall_s: float
    max_time_s: float | None
    cpsat_s: float
    deterministic: bool
    figures: bool
    progress: bool


def parse_args(argv: list[str] | None = None) -> EvaluateArgs:
    p = OneLineParser(prog="cmdp-evaluate", description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--case", type=Path, default=None, help="case file (default: built-in)")
    p.add_argument("--seeds", type=seed_list, default=list(range(20)),
                   help="seeds, e.g. 0-19 (default) or 0,3,5")
    p.add_argument("--strategies", type=spec_list, default=["priority", "nearest", "cpsat"],
                   help="comma-separated evaluators: priority, nearest, ga:PATH, cpsat, "
                        "cpsat:PATH, a stage-2 model .zip (default: priority,nearest,cpsat)")
    p.add_argument("--navigators", type=spec_list, default=["scripted"],
                   help="comma-separated low levels: scripted, a stage-1 model .zip")
    p.add_argument("--workers", type=positive_int, default=default_workers(),
                   help="worker processes (default: every core)")
    p.add_argument("--out", type=Path, default=Path("out/evaluate"))
    p.add_argument("--stall-s", type=positive_seconds, default=3600.0)
    p.add_argument("--max-time-s", type=positive_seconds, default=None)
    p.add_argument("--cpsat-s", type=positive_seconds, default=20.0,
                   help="CP-SAT's time limit for the bound and the plan (default 20)")
    p.add_argument("--deterministic", action="store_true",
                   help="model navigators take their argmax action instead of sampling")
    p.add_argument("--no-figures", action="store_true")
    p.add_argument("--no-progress", action="store_true")
    a = p.parse_args(argv)
    if not a.strategies or not a.navigators:
        p.error("--strategies and --navigators need at least one name each")
    for name, specs in (("--strategies", a.strategies), ("--navigators", a.navigators)):
        if len(set(specs)) != len(specs):
            p.error(f"{name} names one twice")
    return EvaluateArgs(a.case, a.seeds, a.strategies, a.navigators, a.workers, a.out,
                        a.stall_s, a.max_time_s, a.cpsat_s, a.deterministic,
                        not a.no_figures, not a.no_progress)


def _episode_job(runner: EpisodeRunner, spec: str, navigator: str, seed: int) -> dict:
    return runner.run(spec, navigator, seed)


def check_specs(case, strategies: list[str], navigators: list[str],
                deterministic: bool) -> None:
    """Build every evaluator and low level once on the case: a missing file or a model or
    priority file that does not fit the case fails here, before any episode."""
    for spec in strategies:
        make_env(case, make_evaluator(spec), "scripted")
    for spec in navigators:
        env = make_env(case, make_evaluator("priority"), spec)
        make_navigator(spec, env, deterministic)


def evaluate(case, args: EvaluateArgs, run_specs: dict[str, str]) -> list[dict]:
    """Every (navigator, strategy, seed) episode, in that order; ``run_specs`` maps a strategy
    to the spec the workers load (``cpsat`` -> its saved plan)."""
    from tqdm import tqdm

    jobs = [(run_specs[s], n, seed) for n in args.navigators for s in args.strategies
            for seed in args.seeds]
    labels = [(s, n, seed) for n in args.navigators for s in args.strategies
              for seed in args.seeds]
    rows = []
    bar = tqdm(total=len(jobs), unit="episode", disable=not args.progress, mininterval=1.0,
               desc="cmdp-evaluate")
    runner_args = (case, args.stall_s, args.max_time_s, args.deterministic)
    with Workers(_episode_job, runner_args, args.workers) as pool:
        for (strategy, navigator, seed), row in zip(labels, pool.imap(jobs), strict=True):
            rows.append({"strategy": strategy, "navigator": navigator, "seed": seed, **row})
            bar.update(1)
            bar.set_postfix_str(f"{strategy} seed {seed}", refresh=False)
    bar.close()
    return rows


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        case = cmdp_pymunk.load_case(args.case)
        run_specs = {s: s for s in args.strategies}
        check_specs(case, [s for s in args.strategies if s != "cpsat"], args.navigators,
                    args.deterministic)
    except ValueError as err:  # CaseError is a ValueError
        print(f"cmdp-evaluate: {err}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    lb = lower_bound(case)
    from agents.cpsat import save_plan, solve

    cpsat = solve(case, args.cpsat_s)
    print(f"cmdp-evaluate: case {case.case.name!r}: lower bound {lb.lower_bound_s:,.0f} s; "
          f"CP-SAT bound {cpsat.bound_s:,.0f} s "
          f"({'optimal' if cpsat.optimal else 'not proven optimal'}, best schedule "
          f"{cpsat.makespan_s or float('nan'):,.0f} s, {cpsat.wall_s:.1f} s)")
    if "cpsat" in args.strategies:
        try:
            run_specs["cpsat"] = f"cpsat:{save_plan(args.out / 'cpsat_plan.json', case, cpsat)}"
        except ValueError as err:
            print(f"cmdp-evaluate: {err}", file=sys.stderr)
            return 2
    n = len(args.seeds) * len(args.strategies) * len(args.navigators)
    print(f"cmdp-evaluate: {n} episodes ({len(args.strategies)} strategies x "
          f"{len(args.navigators)} low level(s) x {len(args.seeds)} seeds), "
          f"{args.workers} worker(s)")
    start = time.perf_counter()
    rows = evaluate(case, args, run_specs)
    wall = time.perf_counter() - start
    summary = summarize(rows, lb.lower_bound_s, cpsat.bound_s)
    fields = ["strategy", "navigator", "seed", *ROW_FIELDS]
    write_atomic(args.out / "episodes.csv", csv_text(rows, fields))
    write_atomic(args.out / "summary.csv", csv_text(summary, list(summary[0])))
    table = markdown_table(summary, lb.lower_bound_s, cpsat.as_dict())
    write_atomic(args.out / "summary.md", table)
    write_atomic(args.out / "summary.json", json.dumps(summary, indent=1) + "\n")
    settings = {**asdict(args), "case": case.case.name,
                "case_file": str(args.case) if args.case else "built-in",
                "lower_bound": lb.as_dict(), "cpsat": cpsat.as_dict(), "episodes": len(rows),
                "wall_s": round(wall, 1), "episodes_per_s": round(len(rows) / wall, 3),
                "command": sys.argv, "versions": versions()}
    write_atomic(args.out / "settings.json", json.dumps(settings, indent=2, default=str) + "\n")
    if args.figures:
        from media.comparison import draw_comparison

        draw_comparison(rows, args.out)
    print(table, end="")
    print(f"cmdp-evaluate: {len(rows)} episodes in {wall:.0f} s "
          f"({len(rows) / wall:.2f} episodes/s) -> {args.out}")
    return 1 if any(not r["finished"] for r in rows) else 0


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
