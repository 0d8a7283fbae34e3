"""``cmdp-validate-event-floor``: the event floor against the pymunk floor, seed by seed.

    cmdp-validate-event-floor [--case FILE] [--seeds 100-139] [--strategies priority,nearest,...]
                              [--calibration FILE] [--workers N] [--out DIR]

Runs every strategy on every seed on both floors (the same seeds, so the same drawn paces and
disruptions: common random numbers) and prints, per strategy: each floor's mean and P80
makespan and their gap, the per-seed correlation of the two floors' makespans, and the paired
difference to Eq. 9 on each floor (mean and 95 % interval); then whether the strategies rank
the same, Eq. 9's crew-seconds per crew type and category (time use) on both, and the
seconds of CPU a floor costs on each. Issue 30's criteria are checked and printed: correlation
>= 0.9 for Eq. 9, mean and P80 within 3 %, time use within 15 %, the same ranking, paired
differences within +-50 % of the pymunk floor's.

A paired difference measured on 40 seeds carries an interval of about +-400 s on either floor,
as wide as the differences themselves, so the event floor also runs ``--event-seeds`` (default
the validation seeds and the next 260, 300 in all: a few seconds a strategy): its paired
differences and ranking are taken there, and checked against the pymunk floor's (inside its
95 % interval, within +-50 % of its mean, the same order).

The pymunk floors' rows are kept in ``--out`` (``pymunk_rows.json``, by case and seed) and
reused by the next run on the same case (re-calibrating and validating again costs only the
event floors); ``--fresh`` runs them again.

Writes ``validation.json`` (every number, per-seed makespans, the settings and versions) and
``validation.md`` (the tables, as docs/event-floor.md shows them) into ``--out``. Validate on
seeds the calibration was not fitted on (it was fitted on 0-19; the default here is 100-139).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cmdp_pymunk
from cmdp_pymunk.cases.load import BUILTIN_CASE, CaseError, load_case
from cmdp_pymunk.eventfloor.calibration import calibration_for
from cmdp_pymunk.report import versions
from training.cli import OneLineParser, plain, positive_int, seed_list, seeds_text
from training.eventfloor.validation import (
    DEFAULT_STRATEGIES,
    REFERENCE,
    compare,
    event_floors,
    kept_pymunk_rows,
    markdown,
    write_validation,
)
from training.runs.runner import check_specs


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = OneLineParser(prog="cmdp-validate-event-floor", description=plain(__doc__),
                      formatter_class=argparse.RawDescriptionHelpFormatter)
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--case", type=Path, default=None,
                   help="case file (TOML); default: the built-in case")
    p.add_argument("--seeds", type=seed_list, default=list(range(100, 140)),
                   help="held-out seeds (default 100-139)")
    p.add_argument("--strategies", default=",".join(DEFAULT_STRATEGIES),
                   help="comma-separated strategies as cmdp-evaluate takes them; the first "
                        "must be priority (Eq. 9, the reference)")
    p.add_argument("--event-seeds", type=seed_list, default=None,
                   help="seeds for the event floor's paired differences and ranking (default: "
                        "the validation seeds and the next 260)")
    p.add_argument("--fresh", action="store_true",
                   help="run the pymunk floors again instead of reusing --out's rows")
    p.add_argument("--calibration", type=Path, default=None,
                   help="the event floor's calibration (default: beside the case, or built in)")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="processes for the floors (default: every core)")
    p.add_argument("--out", type=Path, default=Path("runs/validate_event_floor"),
                   help="folder for validation.json and validation.md")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    case_path = args.case if args.case is not None else BUILTIN_CASE
    strategies = [s.strip() for s in args.strategies.split(",") if s.strip()]
    if not strategies or strategies[0] != REFERENCE:
        print(f"cmdp-validate-event-floor: --strategies {args.strategies!r}: the first must "
              f"be {REFERENCE} (Eq. 9, the reference of the paired differences); fix: put it "
              "first", file=sys.stderr)
        return 2
    try:
        case = load_case(case_path)
        calibration = calibration_for(case, case_path, args.calibration)
        check_specs(case, strategies, ["scripted"], False)
    except (CaseError, ValueError) as err:
        print(f"cmdp-validate-event-floor: {err}", file=sys.stderr)
        return 2
    if not calibration.calibrated:
        print("cmdp-validate-event-floor: the event floor runs uncalibrated (no calibration "
              "beside the case); fit one with cmdp-calibrate first for a fair comparison")
    seeds = args.seeds
    print(f"cmdp-validate-event-floor: {case.case.name}, {len(strategies)} strategies x "
          f"{len(seeds)} seeds on both floors")
    many_seeds = args.event_seeds or sorted(set(seeds) | set(range(seeds[-1] + 1,
                                                                   seeds[-1] + 261)))
    start = time.perf_counter()
    event, event_many = event_floors(case, calibration, strategies, seeds, many_seeds,
                                     args.workers)
    print(f"  event floors: {time.perf_counter() - start:.1f} s ({len(many_seeds)} seeds)")
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    pymunk = kept_pymunk_rows(case, strategies, seeds, args.workers, args.out, args.fresh)
    print(f"  pymunk floors: {time.perf_counter() - start:.0f} s")
    result = compare(pymunk, event, event_many)
    ms = many_seeds
    result["event_seeds"] = f"{ms[0]}-{ms[-1]}" if ms == list(range(ms[0], ms[-1] + 1)) \
        else f"{len(ms)} seeds"
    table = markdown(result, seeds_text(seeds))
    print("\n" + table)
    record = {"case": case.case.name, "seeds": seeds, "strategies": strategies,
              "calibration": calibration.model_dump(), "versions": versions(),
              "command": "cmdp-validate-event-floor " + " ".join(
                  argv if argv is not None else sys.argv[1:]), **result}
    write_validation(args.out, record, table)
    print(f"wrote {args.out / 'validation.json'} and validation.md")
    return 0


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
