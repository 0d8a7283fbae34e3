"""The event floor's calibration fitted on the pymunk floor (``cmdp-calibrate``,
``training/commands/calibrate.py``; the method is that command's documentation): the pymunk
floors played with their walks recorded (``WalkRecorder``, ``pymunk_floors``), Eq. 1's walks
fitted per crew type (``fit_walks``), then a fixed point of cheap event floors matching each
crew type's crew-seconds walking, working and loading (``fit``).

It sits here, beside the training side's run machinery, not in ``cmdp_pymunk/eventfloor``
(which holds the calibration as data, ``calibration.py``): it plays floors with the scripted
navigator and the named evaluators (``agents``) on worker processes (``training.runs``),
which the simulation core may not import.
"""

from __future__ import annotations

import math
import time

import numpy as np

from agents.navigator import Navigator
from agents.specs import evaluator_from_spec
from cmdp_pymunk.eventfloor.calibration import Calibration, CrewTypeCalibration, fingerprint
from cmdp_pymunk.eventfloor.walks import WalkPlanner
from cmdp_pymunk.policy import best_target
from cmdp_pymunk.report import stall_report
from cmdp_pymunk.rollout import Episode, play
from cmdp_pymunk.timeuse import totals
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


def pymunk_job(runner: EpisodeRunner, evaluator: str, seed: int) -> tuple[dict, list]:
    """One pymunk floor of Eq. 9 (or ``evaluator``) with its walks recorded: (row, walks)."""
    engine = make_engine(runner.case, evaluator_from_spec(evaluator), "scripted")
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
                 f"{mean_of_done([r['makespan_s'] for r in rows]):,.0f} s; largest crew-type "
                 f"mismatch {100 * worst:.1f} %")
        if round_ == iterations or worst < 0.005:
            break
        calibration = Calibration(
            case=case.case.name, fingerprint=fingerprint(case), fitted_on=fitted_on,
            command=command,
            crew_types={ct: refit(calibration.of(ct), target[ct], got[ct])
                        for ct in sorted(target) if ct in got})
    return calibration, rows


def mean_of_done(values) -> float:
    done = [v for v in values if v]
    return float(np.mean(done)) if done else math.nan

def pymunk_floors(case, evaluator: str, seeds: list[int],
                  workers: int | None) -> tuple[list[dict], list[tuple[str, float, float]]]:
    """The case's pymunk floors on ``seeds`` (``evaluator``, the scripted navigator) on
    ``workers`` processes: their episode rows and every recorded walk (``WalkRecorder``)."""
    with open_backend(pymunk_job, (case, 3600.0), workers) as backend:
        results = backend.map([(evaluator, s) for s in seeds])
    return [row for row, _ in results], [w for _, recorded in results for w in recorded]


def fit_table(calibration: Calibration, pymunk_rows: list[dict], rows: list[dict]) -> str:
    """Per crew type, the fitted numbers and the crew-hours of ``FITTED`` on both floors."""
    target, got = crew_type_sums(pymunk_rows), crew_type_sums(rows)
    lines = [f"{'crew type':<10}{'walk factor':>12}{'dock s':>8}{'task inv.':>10}"
             f"{'fetch inv.':>11}   "
             + "   ".join(f"{c} pymunk/event (crew-h)" for c in FITTED)]
    for ct in sorted(target):
        c = calibration.of(ct)
        cells = "   ".join(f"{target[ct][k] / 3600:>9.1f} /{got.get(ct, {}).get(k, 0) / 3600:>6.1f}"
                           for k in FITTED)
        lines.append(f"{ct:<10}{c.walk_factor:>12.3f}{c.dock_s:>8.1f}{c.task_invasion:>10.3f}"
                     f"{c.fetch_invasion:>11.3f}"
                     f"   {cells}")
    return "\n".join(lines)
