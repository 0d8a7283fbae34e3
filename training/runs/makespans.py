"""The end of a ``cmdp-simulate`` run over several seeds: ``makespans.csv`` (a row per seed)
and ``makespans.json`` (the makespans' mean, spread and P50/P80/P90, with a working calendar
their finish dates, the disruptions struck per floor and their mean cost over the seeds with
its 95 % interval), and the console lines that say them.

Apart from the run (``training.runs.simulation``) because it reads only the seeds'
``summary.json`` data, nothing of the floors played.
"""
from __future__ import annotations

import sys
from pathlib import Path

from training.runs.seed_outputs import write_json


def write_makespans(out: Path, rows: list[dict], calendar=None) -> dict:
    """``makespans.csv`` (a row per seed) and ``makespans.json`` (``makespan_stats``, the
    disruptions and their cost); with a working calendar, the finish dates too: a ``finish``
    column and a ``calendar`` entry dating the mean, P50/P80/P90, min and max."""
    from cmdp_pymunk.cost import cost_percentiles
    from cmdp_pymunk.events import write_atomic
    from cmdp_pymunk.report import makespan_stats, seconds_and_hours
    from cmdp_pymunk.workcalendar import calendar_datetime, finish_dates, iso

    costs = [r.get("disruption_cost") for r in rows]
    measured = any(c is not None for c in costs)
    lines = ["seed,makespan_s,makespan_over_lower_bound,tasks_finished,all_finished,reach_rate"
             + (",undisrupted_makespan_s,disruption_delay_s" if measured else "")
             + (",finish" if calendar is not None else "")]
    lines += [f"{r['seed']},{r['makespan_s'] or ''},{r['makespan_over_lower_bound'] or ''},"
              f"{r['tasks_finished']},{r['all_finished']},{r['reach_rate']:.4f}"
              + (f",{_blank(c and c['undisrupted_makespan_s'])},{_blank(c and c['delay_s'])}"
                 if measured else "")
              + ("," + (iso(calendar_datetime(calendar, r["makespan_s"])) if r["makespan_s"]
                        else "") if calendar is not None else "")
              for r, c in zip(rows, costs, strict=True)]
    write_atomic(out / "makespans.csv", "\n".join(lines) + "\n")
    # the floor the episodes ran on first, so that no event-floor result passes for pymunk's
    stats = {"fidelity": rows[0].get("fidelity", "pymunk"),
             "calibration": rows[0].get("calibration"), **makespan_stats(rows),
             **cost_percentiles(rows)}  # cost P50/P80 beside the makespan's
    stats["disruptions"] = mean_struck([r.get("disruptions") for r in rows])
    stats["disruption_cost"] = mean_cost(rows) if measured else None
    stats["calendar"] = finish_dates(calendar, {k: stats[f"{k}_s"] for k in (
        "mean", "p50", "p80", "p90", "min", "max")}) if calendar is not None else None
    write_json(out / "makespans.json", stats)
    if stats["finished"]:
        floor = " on the event floor" if stats["fidelity"] == "event" else ""
        print(f"cmdp-simulate: {stats['finished']}/{len(rows)} episodes finished{floor}; "
              "makespan mean "
              f"{seconds_and_hours(stats['mean_s'])}, std {stats['std_s']:.0f} s, min "
              f"{stats['min_s']:.0f}, max {stats['max_s']:.0f} "
              f"({stats['mean_over_lower_bound']:.2f} x lower bound"
              + (f", {stats['mean_over_seed_bound']:.2f} x seed bound, mean "
                 f"{stats['seed_bound_mean_s']:,.0f} s" if stats["mean_over_seed_bound"] else "")
              + "); "
              f"P50 {stats['p50_s']:.0f} s, P80 {stats['p80_s']:.0f} s, "
              f"P90 {stats['p90_s']:.0f} s")
    if stats["calendar"] is not None and stats["finished"]:
        dates = stats["calendar"]
        print(f"cmdp-simulate: finish dates from {dates['second_0']} ({dates['working_time']}): "
              f"P50 {dates['p50']}, P80 {dates['p80']}, P90 {dates['p90']}")
    if stats["disruptions"] is not None:
        print(f"cmdp-simulate: {mean_cost_text(stats)}")
    if stats["percentiles_note"]:
        print(f"cmdp-simulate: warning: {stats['percentiles_note']}", file=sys.stderr)
    return stats


def _blank(value) -> str:
    return "" if value is None else str(value)


def mean_struck(by_seed: list[dict | None]) -> dict | None:
    """Per kind, the mean over the floors of ``disruption_summary``'s numbers (count,
    downtime_s, idle_crew_s); None for a case without disruptions."""
    import numpy as np

    kept = [d for d in by_seed if d is not None]
    if not kept:
        return None
    return {kind: {what: float(np.mean([d[kind][what] for d in kept])) for what in kept[0][kind]}
            for kind in kept[0]}


def mean_cost(rows: list[dict]) -> dict:
    """What the disruptions cost over the seeds (``training.runs.paired``): the mean delay
    against the same seeds undisrupted with its 95 % interval (Student's t) over the seeds
    where both floors finished, the mean delay in % with its interval, the mean undisrupted
    makespan and the ratio of the means."""
    from training.runs.paired import mean_ci, paired

    floors = [{"seed": r["seed"], "makespan_s": r["makespan_s"], "finished": r["all_finished"]}
              for r in rows if r.get("disruption_cost")]
    plain = [{"seed": r["seed"], "makespan_s": c["undisrupted_makespan_s"],
              "finished": c["undisrupted_makespan_s"] is not None}
             for r in rows if (c := r.get("disruption_cost"))]
    both = paired(floors, plain)
    pct, _, pct_ci = mean_ci([r["disruption_cost"]["delay_pct"] for r in rows
                              if r.get("disruption_cost")])
    undisrupted, _, _ = mean_ci([c["undisrupted_makespan_s"] for r in rows
                                 if (c := r.get("disruption_cost")) and c["delay_s"] is not None])
    return {"paired_seeds": both["paired_seeds"], "delay_mean_s": both["diff_mean_s"],
            "delay_ci95_s": both["diff_ci95_s"], "delay_pct_mean": pct,
            "delay_pct_ci95": pct_ci, "undisrupted_mean_s": undisrupted,
            "ratio": both["ratio"]}


def mean_cost_text(stats: dict) -> str:
    """The disruptions over the seeds and their mean cost, for the console."""
    from cmdp_pymunk.report import struck_text

    text = f"disruptions per floor on average: {struck_text(stats['disruptions'])}"
    cost = stats["disruption_cost"]
    if cost is None:
        return text + "; cost not measured (--no-disruption-cost)"
    if not cost["paired_seeds"]:
        return text + "; cost unknown: no seed finished both with and without them"
    ci = "" if cost["delay_ci95_s"] is None else f" ± {cost['delay_ci95_s']:,.0f}"
    ci_pct = "" if cost["delay_pct_ci95"] is None else f" ± {cost['delay_pct_ci95']:.1f}"
    return (f"{text}; they cost {cost['delay_mean_s']:+,.0f}{ci} s a floor "
            f"({cost['delay_pct_mean']:+.1f}{ci_pct} %; mean, 95 % interval) against "
            f"{cost['undisrupted_mean_s']:,.0f} s on the same {cost['paired_seeds']} seeds "
            "without them")
