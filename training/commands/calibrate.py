"""``cmdp-calibrate``: fit the event floor's numbers on the pymunk floor (issue 30, item 3).

    cmdp-calibrate [--case FILE] [--seeds 0-19] [--evaluator priority] [--workers N]
                   [--iterations 8] [--out FILE]

Runs the case's pymunk floors (the paper's, the ground truth) on the seeds with the evaluator
(Eq. 9 by default) and the scripted navigator, recording every walk (from the second a crew
heads for a target to its reach: ``WalkRecorder``) beside the event floor's Eq. 1 time for the
same walk from the same place, and each crew type's crew-seconds walking, working and loading
(``cmdp_pymunk.timeuse``). Then it fits the event floor's numbers per crew type
(``cmdp_pymunk.eventfloor.calibration``):

- ``dock_s`` and ``walk_factor``: least squares of walk time = walk_factor * Eq. 1 time +
  dock_s over the recorded walks (the turn-and-dock allowance per arrival, and the rest);
- then a fixed point of a few rounds of cheap event floors on the same seeds, matching the
  sums: walk_factor <- walk_factor * walking(pymunk) / walking(event) (the event floor's
  walks are its own, not the pymunk floor's); a task takes work / (pace (1 - invasion))
  (Eq. 2), so 1 - task_invasion <- (1 - task_invasion) * working(event) / working(pymunk);
  ``fetch_invasion`` likewise from loading.

The file is written (whole or not at all) to ``--out``, by default beside the case file as
``<stem>.event.toml`` (the built-in case: ``cmdp_pymunk/cases/precast_floor.event.toml``),
where ``--fidelity event`` finds it. It records the seeds, the evaluator and this command.
Fit on training seeds (0-19), validate on others (``cmdp-validate-event-floor``).
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import cmdp_pymunk
from cmdp_pymunk.cases.load import BUILTIN_CASE, CaseError, load_case
from cmdp_pymunk.eventfloor.calibration import beside, write_calibration
from training.cli import OneLineParser, plain, positive_int, seed_list, seeds_text
from training.eventfloor.fitting import (
    fit,
    fit_table,
    fit_walks,
    mean_of_done,
    pymunk_floors,
)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = OneLineParser(prog="cmdp-calibrate", description=plain(__doc__),
                      formatter_class=argparse.RawDescriptionHelpFormatter)
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--case", type=Path, default=None,
                   help="case file (TOML); default: the built-in case")
    p.add_argument("--seeds", type=seed_list, default=list(range(20)),
                   help="training seeds to fit on, e.g. 0-19 (default)")
    p.add_argument("--evaluator", default="priority",
                   help="the strategy whose pymunk floors are matched (default: priority, Eq. 9)")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="processes for the pymunk floors (default: every core)")
    p.add_argument("--iterations", type=positive_int, default=8,
                   help="fixed-point rounds at most (default 8)")
    p.add_argument("--out", type=Path, default=None,
                   help="where to write the calibration (default: <case stem>.event.toml "
                        "beside the case file)")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    case_path = args.case if args.case is not None else BUILTIN_CASE
    try:
        case = load_case(case_path)
    except CaseError as err:
        print(err, file=sys.stderr)
        return 2
    out = args.out if args.out is not None else beside(case_path)
    if not out.parent.is_dir():
        print(f"cmdp-calibrate: --out {out}: no such folder; fix: create it or give another "
              "path", file=sys.stderr)
        return 2
    seeds = args.seeds
    given = argv if argv is not None else sys.argv[1:]
    command = " ".join(["cmdp-calibrate", *(shlex.quote(a) for a in given)])
    fitted_on = (f"{args.evaluator}, seeds {seeds_text(seeds)}, pymunk floor, cmdp-pymunk "
                 f"{cmdp_pymunk.__version__}")
    print(f"cmdp-calibrate: {case.case.name}: {len(seeds)} pymunk floors ({args.evaluator}, "
          f"scripted navigator), then the event floor fitted to them")
    start = time.perf_counter()
    pymunk_rows, walks = pymunk_floors(case, args.evaluator, seeds, args.workers)
    unfinished = [s for s, r in zip(seeds, pymunk_rows, strict=True) if not r["finished"]]
    print(f"  pymunk floors: {time.perf_counter() - start:.0f} s; mean makespan "
          f"{mean_of_done([r['makespan_s'] for r in pymunk_rows]):,.0f} s"
          + (f"; unfinished seeds {unfinished} left out" if unfinished else ""))
    print(f"  {len(walks)} walks recorded; least squares per crew type: "
          + ", ".join(f"{ct} {f:.2f} x + {d:.1f} s" for ct, (f, d) in fit_walks(walks).items()))
    calibration, rows = fit(case, pymunk_rows, seeds, args.evaluator, args.iterations,
                            fitted_on, command, walks=walks)
    write_calibration(calibration, out)
    print("\n" + fit_table(calibration, pymunk_rows, rows))
    print(f"\nwrote {out} (use it with --fidelity event; validate on other seeds with "
          "cmdp-validate-event-floor)")
    return 0


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
