"""One seed of ``cmdp-simulate``: ``summary.json``'s data, the episode as a worker sends it
back (``SeedRun``; ``_simulate_job`` is what a worker runs) and every file of the seed's
folder, each written atomically: ``summary.json``, ``events.csv``, ``schedule.csv``, the same
schedule as MS Project XML (``schedule.xml``, for MS Project and the tools that read its XML),
the 4D IFC, the stall picture, the Gantt charts and the GIF's pace.

Apart from the run (``training.runs.simulation``) because a seed's files are the same whichever
way its floor was played: in the command's process, on a worker process or on Ray.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: the run imports this module
    from training.runs.simulation import SimulateArgs


DEFAULT_IFC_START = "2026-01-05T08:00:00"  # second 0 of the 4D export without a calendar
MSPDI_FILE = "schedule.xml"  # the schedule as MS Project XML (cmdp_pymunk.exchange.mspdi)
GIF_SECONDS = 30.0
GIF_FPS = 10


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
