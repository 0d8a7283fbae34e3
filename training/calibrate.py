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
import math
import shlex
import sys
import time
from pathlib import Path

import numpy as np

import cmdp_pymunk
from agents.navigator import Navigator
from agents.specs import make_evaluator
from cmdp_pymunk.cases.load import BUILTIN_CASE, CaseError, load_case
from cmdp_pymunk.eventfloor.calibration import (
    Calibration,
    CrewTypeCalibration,
    beside,
    fingerprint,
    write_calibration,
)
from cmdp_pymunk.eventfloor.walks import WalkPlanner
from cmdp_pymunk.policy import best_target
from cmdp_pymunk.rollout import Episode, play, stall_report
from cmdp_pymunk.timeuse import totals
from training.cli import OneLineParser, plain, positive_int
from training.compare import seed_list
from training.runs.backends import open_backend
from training.runs.runner import TIME_USE, EpisodeRunner, episode_row, make_engine

FITTED = ("walking", "working", "loading")  # the time-use categories matched
MAX_INVASION = 0.9


def _rows(runner: EpisodeRunner, evaluator: str, seeds: list[int]) -> list[dict]:
    return [runner.run(evaluator, "scripted", seed) for seed in seeds]


class WalkRecorder:
    """Every clean walk of a pymunk floor, as (crew type, Eq. 1 time, time taken): from the
    second a crew on the move first holds a best target to the second it reaches it (the
    event log's ``reach``), with the event floor's Eq. 1 time for that walk from where it
    stood then (``walks.WalkPlanner``, walk factor 1, no allowance). A walk whose target
    changes on the way is dropped: the event floor re-plans such walks from where the crew
    turns. ``observe`` is called before every advance of the floor (``rollout.play``)."""

    def __init__(self, engine):
        self.engine = engine
        self.planner = WalkPlanner(engine.site)
        self.open: dict[int, tuple[float, int, int, float]] = {}
        self.walks: list[tuple[str, float, float]] = []

    def observe(self) -> None:
        engine = self.engine
        site = engine.site
        for crew in site.crews:
            i = crew.index
            target = best_target(crew) if crew.moving else -1
            held = self.open.get(i)
            if held is not None:
                since, aim, reaches, eq1 = held
                if crew.stats.reaches > reaches:  # reached (maybe seconds ago: the idle jump)
                    reached = next(e.time_s for e in reversed(engine.log.events)
                                   if e.kind == "reach" and e.crew == crew.id)
                    self.walks.append((crew.type, eq1, reached - since))
                    held = None
                elif target != aim:
                    held = None
                if held is None:
                    del self.open[i]
            if held is None and target >= 0:
                walk = self.planner.walk(site, crew, engine.positions[i], target,
                                         site.time_s, 1.0)
                self.open[i] = (site.time_s, target, crew.stats.reaches, float(walk.times[-1]))


def _pymunk_job(runner: EpisodeRunner, evaluator: str, seed: int) -> tuple[dict, list]:
    """One pymunk floor of Eq. 9 (or ``evaluator``) with its walks recorded: (row, walks)."""
    engine = make_engine(runner.case, make_evaluator(evaluator), "scripted")
    engine.stall_s = runner.stall_s
    navigator = Navigator()
    engine.reset(seed)
    navigator.reset(seed)
    recorder = WalkRecorder(engine)
    start = time.perf_counter()
    play(engine, navigator, None, recorder.observe)
    stalled = stall_report(engine, engine.stalled["after_s"]) if engine.stalled else None
    episode = Episode(seed, engine.makespan_s, time.perf_counter() - start, stalled)
    return episode_row(engine, episode), recorder.walks


def fit_walks(walks: list[tuple[str, float, float]]) -> dict[str, tuple[float, float]]:
    """(walk_factor, dock_s) per crew type: least squares of time = factor * Eq. 1 time +
    dock_s, dock_s >= 0 (refitted through the origin where the free fit goes below)."""
    out = {}
    for crew_type in sorted({w[0] for w in walks}):
        eq1 = np.array([w[1] for w in walks if w[0] == crew_type])
        taken = np.array([w[2] for w in walks if w[0] == crew_type])
        if len(eq1) < 3 or eq1.sum() <= 0:
            continue
        (factor, dock), *_ = np.linalg.lstsq(np.vstack([eq1, np.ones_like(eq1)]).T, taken,
                                             rcond=None)
        if dock < 0 or factor <= 0:
            factor, dock = float(eq1 @ taken / (eq1 @ eq1)), 0.0
        out[crew_type] = (min(20.0, max(0.05, float(factor))), min(600.0, float(dock)))
    return out


def crew_type_sums(rows: list[dict]) -> dict[str, dict[str, float]]:
    """Crew-seconds per crew type in ``FITTED``'s categories, summed over the rows
    (finished floors only)."""
    out: dict[str, dict[str, float]] = {}
    for row in rows:
        if not row["finished"]:
            continue
        for crew_type, use in totals(row[TIME_USE]).items():
            sums = out.setdefault(crew_type, dict.fromkeys(FITTED, 0.0))
            for category in FITTED:
                sums[category] += use[category]
    return out


def refit(current: CrewTypeCalibration, pymunk: dict[str, float],
          event: dict[str, float]) -> CrewTypeCalibration:
    """One fixed-point round for one crew type (see the module doc); a category either floor
    spent no time in keeps its number."""
    walk, task, fetch = current.walk_factor, current.task_invasion, current.fetch_invasion
    # the walks' allowance stays as fitted; their factor takes up what the event floor's own
    # walks (another trajectory) spend otherwise
    if pymunk["walking"] > 0 and event["walking"] > 0:
        walk = min(20.0, max(0.05, walk * pymunk["walking"] / event["walking"]))
    if pymunk["working"] > 0 and event["working"] > 0:
        task = 1.0 - (1.0 - task) * event["working"] / pymunk["working"]
    if pymunk["loading"] > 0 and event["loading"] > 0:
        fetch = 1.0 - (1.0 - fetch) * event["loading"] / pymunk["loading"]
    clip = lambda v: min(MAX_INVASION, max(0.0, v))  # noqa: E731
    return CrewTypeCalibration(walk_factor=round(walk, 4), dock_s=current.dock_s,
                               task_invasion=round(clip(task), 4),
                               fetch_invasion=round(clip(fetch), 4))


def fit(case, pymunk_rows: list[dict], seeds: list[int], evaluator: str = "priority",
        iterations: int = 8, fitted_on: str = "", command: str = "",
        progress=print, walks: list | None = None) -> tuple[Calibration, list[dict]]:
    """The calibration that matches the pymunk rows' crew-type sums on the event floor
    (starting from ``fit_walks`` of the recorded ``walks``), and the event floor's rows under
    it (see the module doc)."""
    target = crew_type_sums(pymunk_rows)
    fitted = fit_walks(walks or [])
    calibration = Calibration(
        case=case.case.name, fingerprint=fingerprint(case), fitted_on=fitted_on,
        command=command,
        crew_types={ct: CrewTypeCalibration(walk_factor=round(f, 4), dock_s=round(d, 2))
                    for ct, (f, d) in fitted.items()})
    rows: list[dict] = []
    for round_ in range(iterations + 1):
        runner = EpisodeRunner(case, fidelity="event", calibration=calibration)
        rows = _rows(runner, evaluator, seeds)
        got = crew_type_sums(rows)
        worst = max((abs(got[ct][c] / target[ct][c] - 1.0) for ct in target for c in FITTED
                     if target[ct][c] > 0 and ct in got), default=0.0)
        progress(f"  round {round_}: event floor mean makespan "
                 f"{_mean([r['makespan_s'] for r in rows]):,.0f} s; largest crew-type "
                 f"mismatch {100 * worst:.1f} %")
        if round_ == iterations or worst < 0.005:
            break
        calibration = Calibration(
            case=case.case.name, fingerprint=fingerprint(case), fitted_on=fitted_on,
            command=command,
            crew_types={ct: refit(calibration.of(ct), target[ct], got[ct])
                        for ct in sorted(target) if ct in got})
    return calibration, rows


def _mean(values) -> float:
    done = [v for v in values if v]
    return float(np.mean(done)) if done else math.nan


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
    fitted_on = (f"{args.evaluator}, seeds {_seed_text(seeds)}, pymunk floor, cmdp-pymunk "
                 f"{cmdp_pymunk.__version__}")
    print(f"cmdp-calibrate: {case.case.name}: {len(seeds)} pymunk floors ({args.evaluator}, "
          f"scripted navigator), then the event floor fitted to them")
    start = time.perf_counter()
    with open_backend(_pymunk_job, (case, 3600.0), args.workers) as backend:
        results = backend.map([(args.evaluator, s) for s in seeds])
    pymunk_rows = [row for row, _ in results]
    walks = [w for _, recorded in results for w in recorded]
    unfinished = [s for s, r in zip(seeds, pymunk_rows, strict=True) if not r["finished"]]
    print(f"  pymunk floors: {time.perf_counter() - start:.0f} s; mean makespan "
          f"{_mean([r['makespan_s'] for r in pymunk_rows]):,.0f} s"
          + (f"; unfinished seeds {unfinished} left out" if unfinished else ""))
    print(f"  {len(walks)} walks recorded; least squares per crew type: "
          + ", ".join(f"{ct} {f:.2f} x + {d:.1f} s" for ct, (f, d) in fit_walks(walks).items()))
    calibration, rows = fit(case, pymunk_rows, seeds, args.evaluator, args.iterations,
                            fitted_on, command, walks=walks)
    write_calibration(calibration, out)
    target, got = crew_type_sums(pymunk_rows), crew_type_sums(rows)
    print(f"\n{'crew type':<10}{'walk factor':>12}{'dock s':>8}{'task inv.':>10}"
          f"{'fetch inv.':>11}   "
          + "   ".join(f"{c} pymunk/event (crew-h)" for c in FITTED))
    for ct in sorted(target):
        c = calibration.of(ct)
        cells = "   ".join(f"{target[ct][k] / 3600:>9.1f} /{got.get(ct, {}).get(k, 0) / 3600:>6.1f}"
                           for k in FITTED)
        print(f"{ct:<10}{c.walk_factor:>12.3f}{c.dock_s:>8.1f}{c.task_invasion:>10.3f}"
              f"{c.fetch_invasion:>11.3f}"
              f"   {cells}")
    print(f"\nwrote {out} (use it with --fidelity event; validate on other seeds with "
          "cmdp-validate-event-floor)")
    return 0


def _seed_text(seeds: list[int]) -> str:
    if seeds == list(range(seeds[0], seeds[-1] + 1)):
        return f"{seeds[0]}-{seeds[-1]}"
    return ",".join(map(str, seeds))


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
