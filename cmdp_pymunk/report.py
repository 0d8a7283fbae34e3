"""Summing episodes up: what a run folder records and the console says of them.

``stall_report`` says who and what was stuck in a floor that stopped making progress
(``stall_text`` says it in prose); ``crew_summary``, ``disruption_summary``,
``disruption_cost``, ``reach_rate``, ``makespan_stats`` (mean, P50/P80/P90) and ``versions``
(the packages and the commit) are what ``cmdp-simulate``, ``cmdp-train``, the comparisons
and the searches write. Episodes are played by ``cmdp_pymunk.rollout``.
"""

from __future__ import annotations

import functools
import math
import platform
import subprocess
from pathlib import Path

import numpy as np

from . import disruptions
from .decide import target_id
from .engine import Engine
from .policy import best_target
from .state import DISRUPTION_CAUSES, CrewStatus, IdleCause, Pool, activity

PERCENTILES = (50, 80, 90)  # the makespan percentiles a run of many episodes reports
# Below this many finished floors a P80 or P90 rests on the two or three largest makespans:
# outputs say so (issue 31). With n floors, P90 is interpolated between the n*0.9-th order
# statistics; 20 floors put two of them above it.
MIN_FLOORS_FOR_PERCENTILES = 20


def percentiles_note(finished: int) -> str:
    """A warning for P80/P90 taken from too few finished floors ("" from
    ``MIN_FLOORS_FOR_PERCENTILES`` on)."""
    if finished >= MIN_FLOORS_FOR_PERCENTILES:
        return ""
    return (f"P80/P90 from {finished} finished floor{'s' if finished != 1 else ''} (fewer than "
            f"{MIN_FLOORS_FOR_PERCENTILES}): they rest on the few longest; run more episodes "
            "before planning on them")


def seconds_and_hours(seconds: float) -> str:
    """A duration for people: "33,943 s (9.43 h)"."""
    return f"{seconds:,.0f} s ({seconds / 3600:.2f} h)"


# How people read each kind of disruption (``disruptions.KIND_ORDER``): one, many.
KIND_WORDS = {"crane_breakdown": ("crane breakdown", "crane breakdowns"),
              "late_delivery": ("late delivery", "late deliveries"),
              "absence": ("absence", "absences"),
              "weather": ("weather stop", "weather stops")}


def struck_text(by_kind: dict) -> str:
    """What struck, for people: "2 crane breakdowns (3,120 s down), 1 absence (3,600 s
    down)" from ``disruption_summary``'s counts and downtimes (means over floors give
    "1.5 crane breakdowns"); "no disruption struck" when none did."""
    parts = []
    for kind, (one, many) in KIND_WORDS.items():
        count = by_kind[kind]["count"]
        if count:
            number = f"{count:g}" if isinstance(count, int) or count == int(count) \
                else f"{count:.1f}"
            parts.append(f"{number} {one if count == 1 else many} "
                         f"({by_kind[kind]['downtime_s']:,.0f} s down)")
    return ", ".join(parts) if parts else "no disruption struck"


def stall_report(engine: Engine, for_s: float, ways: dict | None = None) -> dict:
    """The crews and tasks involved in an episode that stopped making progress.

    Per crew still on the floor: its id, type, radius, activity, position, target scope
    (``targets``), task, the seconds it has held a target without reaching one
    (``steps_since_reach``), and, for a crew walking to a target, ``heading_for``: the target
    (``target``, ``task`` for a work point, ``position_m``, ``distance_m`` from the crew) and
    ``way_m``, the cells its low level means to walk (``ways``: crew index -> points, from a
    ``policy.ShowsWay`` low level; absent without one). ``stall_text`` reads it as prose."""
    site = engine.site
    crews = []
    for crew in site.crews:
        if crew.status == CrewStatus.LEFT:
            continue
        x, y, _ = engine.pose(crew.index)
        row = {"crew": crew.id, "type": crew.type, "radius_m": round(crew.spec.radius_m, 2),
               "activity": activity(crew), "position_m": [round(x, 2), round(y, 2)],
               "targets": sorted(target_id(site, t) for t in crew.scope),
               "task": site.tasks[crew.task].id if crew.task >= 0 else None,
               "steps_since_reach": crew.steps_since_reach,
               "heading_for": _heading_for(site, crew, x, y)}
        if ways and ways.get(crew.index):
            row["way_m"] = [[round(px, 2), round(py, 2)] for px, py in ways[crew.index]]
        crews.append(row)
    return {"after_s": for_s, "time_s": site.time_s, "crews": crews,
            "tasks": len(site.tasks), "tasks_ended": site.tasks_ended,
            "tasks_on": [t.id for t in site.tasks if t.pool == Pool.ON],
            "tasks_queued": [t.id for t in site.tasks if t.pool == Pool.QUEUE]}


def _heading_for(site, crew, x: float, y: float) -> dict | None:
    """The target a walking crew heads for (the one every low level takes), or None."""
    target = best_target(crew) if crew.moving else -1
    if target < 0:
        return None
    tx, ty = site.target_xy[target]
    task = crew.scope.get(target, -1) if target < len(site.components) else -1
    return {"target": target_id(site, target), "task": site.tasks[task].id if task >= 0 else None,
            "position_m": [round(float(tx), 2), round(float(ty), 2)],
            "distance_m": round(math.hypot(tx - x, ty - y), 2)}


# How the stall report's activities read in prose.
ACTIVITY_WORDS = {"tasking": "is working on", "fetching": "is fetching materials",
                  "waiting": "is waiting for the crane", "deregistered": "is walking out",
                  "idle_predecessor": "is idle, waiting for a predecessor",
                  "idle_area": "is idle, its work points closed by task areas",
                  "idle_no_target": "is idle with nothing to do"}


def stall_text(report: dict) -> str:
    """``stall_report`` in prose for people: when and for how long nothing moved on, each
    walking crew's target and how far it stands from it, what the others do, the tasks on
    and queued. E.g. "At t = 21,183 s no task had moved on for 3,600 s; 33 of 36 tasks
    ended. FC-2 (FC, 1.13 m radius) has held a target for 3,600 s without reaching one:
    it walks to task F-14's work point at P-24 (12.30, -2.00) m and stands at (12.30,
    -4.00) m, 2.0 m from it ..."."""
    lines = [f"At t = {report['time_s']:,.0f} s no task had moved on for "
             f"{report['after_s']:,.0f} s"
             + (f"; {report['tasks_ended']} of {report['tasks']} tasks ended."
                if "tasks" in report else ".")]
    for crew in report["crews"]:
        lines.append(_crew_sentence(crew) + _nearest_crew(crew, report["crews"]))
    lines.append("Tasks on: " + (", ".join(report["tasks_on"]) or "none") + "; queued: "
                 + (", ".join(report["tasks_queued"]) or "none") + ".")
    return "\n".join(lines)


def _crew_sentence(crew: dict) -> str:
    """One crew of a stall report in a sentence."""
    x, y = crew["position_m"]
    who = f"{crew['crew']} ({crew['type']}, {crew['radius_m']:.2f} m radius)" \
        if "type" in crew else crew["crew"]
    here = f"({x:.2f}, {y:.2f}) m"
    goal = crew.get("heading_for")
    if goal is None:
        doing = ACTIVITY_WORDS.get(crew["activity"], crew["activity"].replace("_", " "))
        if crew["activity"] == "tasking" and crew["task"]:
            doing += f" {crew['task']}"
        return f"{who} {doing}, at {here}."
    gx, gy = goal["position_m"]
    what = f"task {goal['task']}'s work point at {goal['target']}" if goal["task"] else \
        "the outlet" if goal["target"] == "outlet" else f"storage {goal['target']}"
    way = crew.get("way_m") or []
    planned = f"; its planned way runs {_way_length(way):.1f} m from there" if len(way) > 1 \
        else ""
    return (f"{who} has held a target for {crew['steps_since_reach']:,} s without reaching "
            f"one: it walks to {what} ({gx:.2f}, {gy:.2f}) m and stands at {here}, "
            f"{goal['distance_m']:.1f} m from it{planned}.")


def _nearest_crew(crew: dict, crews: list[dict]) -> str:
    """" The nearest crew, X, is 0.2 m from it." for a walking crew ("" otherwise): the
    first suspect when a crew stops short of its target."""
    if crew.get("heading_for") is None:
        return ""
    others = [(math.dist(crew["position_m"], o["position_m"]) - crew.get("radius_m", 0.0)
               - o.get("radius_m", 0.0), o["crew"]) for o in crews if o is not crew]
    if not others:
        return ""
    gap, other = min(others)
    return f" The nearest crew, {other}, is {max(gap, 0.0):.1f} m from it (edge to edge)."


def _way_length(way: list) -> float:
    return float(sum(math.dist(a, b) for a, b in zip(way, way[1:], strict=False)))


def crew_summary(engine: Engine) -> dict:
    """Per crew: reaching steps, idle steps by cause (with a case's disruptions, also the
    seconds each kind of disruption kept it from working), distance, trips, crane waits,
    contacts, reaches and reach time-outs of the episode so far."""
    out = {}
    site = engine.site
    disrupted = bool(site.case.disruptions)
    for crew in site.crews:
        s = crew.stats
        out[crew.id] = {
            "type": crew.type,
            "reaching_steps": s.reaching_steps,
            "idle_steps": {"waiting_for_predecessor": s.idle_steps[IdleCause.PREDECESSOR],
                           "blocked_by_task_area": s.idle_steps[IdleCause.AREA],
                           "no_target": s.idle_steps[IdleCause.NO_TARGET]},
            "distance_m": round(s.distance_m, 2),
            "material_trips": s.material_trips,
            "crane_waits": s.crane_waits,
            "crane_wait_s": s.crane_wait_steps,
            "collisions": s.collisions,
            "congestion_entries": s.congestion_entries,
            "reaches": s.reaches,
            "reach_timeouts": s.reach_timeouts,
        }
        if disrupted:
            out[crew.id]["idle_steps"].update(
                {c.name.lower(): s.idle_steps[c] for c in DISRUPTION_CAUSES})
    return out


def disruption_summary(engine: Engine) -> dict | None:
    """What disruptions struck the engine's episode so far, per kind (``crane_breakdown``,
    ``late_delivery``, ``absence``, ``weather``): ``count`` and ``downtime_s``
    (``disruptions.struck``: seconds down, summed over what they struck) and ``idle_crew_s``,
    the crew-seconds they kept crews from working (the crews' idle steps by cause). None for
    a case without disruptions."""
    site = engine.site
    if not site.case.disruptions:
        return None
    out = disruptions.struck(engine.log.events, site.time_s)
    for cause in DISRUPTION_CAUSES:
        out[disruptions.KIND_NAMES[cause]]["idle_crew_s"] = sum(
            c.stats.idle_steps[cause] for c in site.crews)
    return out


def disruption_cost(makespan_s: float | None, undisrupted_makespan_s: float | None,
                    by_kind: dict | None = None) -> dict:
    """What the disruptions cost a floor: its makespan against the same seed's on the case
    without them (``disruptions.undisrupted``; the same paces, so the difference is theirs
    alone). ``delay_s`` = makespan - undisrupted makespan, ``delay_pct`` = 100 * delay /
    undisrupted makespan; both None unless both floors finished (a floor that stalled or ran
    out of time has no makespan). ``by_kind``: what struck (``disruption_summary``)."""
    delay = makespan_s - undisrupted_makespan_s \
        if makespan_s is not None and undisrupted_makespan_s is not None else None
    return {"undisrupted_makespan_s": undisrupted_makespan_s, "delay_s": delay,
            "delay_pct": 100.0 * delay / undisrupted_makespan_s
            if delay is not None and undisrupted_makespan_s > 0 else None,
            "by_kind": by_kind}


def reach_rate(reaches: int, timeouts: int) -> float:
    """Targets reached over attempts: an attempt that holds a target for the step cap
    (``reevaluate_after_steps``) without reaching counts as a miss each time (``timeouts``).
    0 when there was no attempt."""
    return reaches / max(1, reaches + timeouts)


def episode_reach_rate(engine: Engine) -> float:
    """``reach_rate`` over every crew of the engine's episode so far."""
    crews = engine.site.crews
    return reach_rate(sum(c.stats.reaches for c in crews),
                      sum(c.stats.reach_timeouts for c in crews))


def episode_seed_bound(engine: Engine):
    """``bounds.seed_lower_bound`` of the floor the engine plays (its streams' seed: the paces
    its tasks draw), or None in stage 1, whose tasks take no time (section 4.2)."""
    from .bounds import seed_lower_bound

    if engine.stage != 2:
        return None
    return seed_lower_bound(engine.case, engine.streams.entropy)


def over_seed_bound(rows: list[dict]) -> float | None:
    """The mean over finished episodes of makespan / that seed's bound (``seed_bound_s``):
    each floor against what its own drawn paces allow, averaged (None where no row has both)."""
    ratios = [r["makespan_s"] / r["seed_bound_s"] for r in rows
              if r.get("makespan_s") and r.get("seed_bound_s")]
    return float(np.mean(ratios)) if ratios else None


def makespan_stats(rows: list[dict]) -> dict:
    """Mean, spread and percentiles over episodes, from their summaries (``cmdp-simulate``'s
    ``summary.json``: ``makespan_s`` None for an unfinished episode, ``reach_rate``,
    ``lower_bound`` if known, ``seed_bound_s`` if known).

    Means and percentiles are over the finished episodes; ``finished`` says how many.
    ``p50_s``, ``p80_s`` and ``p90_s`` are the makespans that 50, 80 and 90 % of them stay
    within (``numpy.percentile``, linear between order statistics): a planner's P50/P80/P90.
    """
    done = [r["makespan_s"] for r in rows if r["makespan_s"]]
    lower = rows[0].get("lower_bound", {}).get("lower_bound_s")
    quantiles = np.percentile(done, PERCENTILES).tolist() if done else [None] * len(PERCENTILES)
    return {"episodes": len(rows), "finished": len(done),
            "mean_s": float(np.mean(done)) if done else None,
            "std_s": float(np.std(done)) if done else None,
            "min_s": min(done, default=None), "max_s": max(done, default=None),
            **{f"p{q}_s": v for q, v in zip(PERCENTILES, quantiles, strict=True)},
            "lower_bound_s": lower,
            "mean_over_lower_bound": float(np.mean(done)) / lower if done and lower else None,
            "seed_bound_mean_s": _mean_of([r.get("seed_bound_s") for r in rows]),
            "mean_over_seed_bound": over_seed_bound(rows),
            "mean_reach_rate": float(np.mean([r["reach_rate"] for r in rows])),
            "percentiles_note": percentiles_note(len(done)),
            "makespans_s": [r["makespan_s"] for r in rows]}


def _mean_of(values: list) -> float | None:
    known = [v for v in values if v is not None]
    return float(np.mean(known)) if known else None


def versions() -> dict:
    """Versions of this package, Python and the simulation stack, and the git commit (None
    outside a checkout), for every run folder. The RL libraries' versions are read from their
    installed metadata (None where absent): the core does not import them.

    Found once per process (the code a process runs does not change under it): a git call
    and two metadata look-ups cost about 6 ms, asked for each of a run's seeds."""
    return dict(_versions())


@functools.cache
def _versions() -> dict:
    from importlib import metadata

    import pymunk

    from .about import __version__

    def installed(name: str) -> str | None:
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            return None

    out = {"cmdp_pymunk": __version__, "python": platform.python_version(),
           "pymunk": pymunk.version, "numpy": np.__version__,
           "gymnasium": installed("gymnasium"), "pettingzoo": installed("pettingzoo")}
    try:
        out["commit"] = subprocess.run(
            ["git", "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5,
            cwd=Path(__file__).resolve().parent).stdout.strip() or None
    except (OSError, subprocess.SubprocessError):
        out["commit"] = None
    return out
