"""Summing up a comparison of strategies: means with 95 % intervals, paired differences to the
priority heuristic over the same seeds, and the table in Markdown and CSV.

Rows are ``training.runs.runner.episode_row`` dicts with ``strategy``, ``navigator`` and ``seed``
added. Means of makespan are over the finished episodes; the other columns over every
episode. A strategy's episodes that stalled or timed out are counted and listed, never
dropped silently.
"""

from __future__ import annotations

import math

import numpy as np

from cmdp_pymunk.disruptions import STRUCK_FIELDS
from cmdp_pymunk.report import MIN_FLOORS_FOR_PERCENTILES, over_seed_bound, percentiles_note
from cmdp_pymunk.state import DISRUPTION_IDLE_FIELDS

REFERENCE = "priority"


def mean_ci(values) -> tuple[float | None, float | None, float | None]:
    """Mean, sample standard deviation and the half-width of the 95 % interval of the mean
    (Student's t with n - 1 degrees of freedom); std and interval None for fewer than 2."""
    from scipy import stats

    x = np.asarray([v for v in values if v is not None], dtype=float)
    if len(x) == 0:
        return None, None, None
    if len(x) == 1:
        return float(x[0]), None, None
    std = float(np.std(x, ddof=1))
    return float(x.mean()), std, float(stats.t.ppf(0.975, len(x) - 1) * std / math.sqrt(len(x)))


def count_interval(mean: float | None, half: float | None) -> tuple[float | None, float | None]:
    """The 95 % interval of a mean count (steps, crane waits): mean -/+ the t half-width, its
    lower end clipped at 0 (a count cannot be negative; Student's t on a handful of skewed
    counts reached -3,600 idle steps). (None, None) without an interval."""
    if mean is None or half is None:
        return None, None
    return max(0.0, mean - half), mean + half


def percentile(values, q: float) -> float | None:
    """The makespan q % of the finished episodes stay within (a planner's P50/P80/P90):
    ``numpy.percentile`` at q, linear between order statistics; None without any."""
    x = [v for v in values if v is not None]
    return float(np.percentile(x, q)) if x else None


def p80(values) -> float | None:
    """``percentile(values, 80)``, the planner's P80."""
    return percentile(values, 80)


def paired(rows: list[dict], reference: list[dict]) -> dict:
    """The strategy against the reference on the seeds both finished: mean difference of
    makespan (strategy - reference) with its 95 % interval, and the ratio of the means."""
    ref = {r["seed"]: r["makespan_s"] for r in reference if r["finished"]}
    pairs = [(r["makespan_s"], ref[r["seed"]]) for r in rows
             if r["finished"] and r["seed"] in ref]
    if not pairs:
        return {"paired_seeds": 0, "diff_mean_s": None, "diff_ci95_s": None, "ratio": None}
    mine, theirs = np.array(pairs, dtype=float).T
    diff, _, ci = mean_ci(mine - theirs)
    return {"paired_seeds": len(pairs), "diff_mean_s": diff, "diff_ci95_s": ci,
            "ratio": float(mine.mean() / theirs.mean())}


def seed_bound_mean(group: list[dict]) -> float | None:
    """The mean of the episodes' seed bounds (``seed_bound_s``; None where none has one)."""
    known = [r["seed_bound_s"] for r in group if r.get("seed_bound_s") is not None]
    return float(np.mean(known)) if known else None


def summarize(rows: list[dict], lower_bound_s: float, cpsat_bound_s: float | None) -> list[dict]:
    """One entry per (strategy, navigator), in the order they first appear in ``rows``."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["strategy"], r["navigator"]), []).append(r)
    out = []
    for (strategy, navigator), group in groups.items():
        finished = [r["makespan_s"] for r in group if r["finished"]]
        mean, std, ci = mean_ci(finished)
        entry = {
            "strategy": strategy, "navigator": navigator, "episodes": len(group),
            "finished": len(finished),
            "stalled": sum(r["stalled"] for r in group),
            "timed_out": sum(r["timed_out"] for r in group),
            "stalled_seeds": [r["seed"] for r in group if r["stalled"]],
            "timed_out_seeds": [r["seed"] for r in group if r["timed_out"]],
            "makespan_mean_s": mean, "makespan_std_s": std, "makespan_ci95_s": ci,
            "makespan_p80_s": p80(finished),
            "makespan_p50_s": percentile(finished, 50),
            "makespan_p90_s": percentile(finished, 90),
            "percentiles_note": percentiles_note(len(finished)),
            "over_lower_bound": mean / lower_bound_s if mean else None,
            "over_cpsat_bound": mean / cpsat_bound_s if mean and cpsat_bound_s else None,
            # each seed against the bound on its own floor (drawn paces, loading; issue 32)
            "seed_bound_mean_s": seed_bound_mean(group),
            "over_seed_bound": over_seed_bound([r for r in group if r["finished"]]),
        }
        for key in ("reaching_steps", "idle_waiting_for_predecessor",
                    "idle_blocked_by_task_area", "idle_no_target", "crane_waits",
                    "crane_wait_s", *DISRUPTION_IDLE_FIELDS):
            m, _, c = mean_ci([r.get(key, 0) for r in group])
            entry[f"{key}_mean"], entry[f"{key}_ci95"] = m, c
            entry[f"{key}_ci95_low"], entry[f"{key}_ci95_high"] = count_interval(m, c)
        reference = groups.get((REFERENCE, navigator))
        entry.update({f"vs_{REFERENCE}_{k}": v for k, v in
                      paired(group, reference or []).items()})
        entry.update(disruption_means(group))
        out.append(entry)
    return out


def time_use_summary(rows: list[dict], key: str = "time_use_s") -> list[dict]:
    """Where the time goes, per (strategy, low level, crew type, phase, category): the mean
    crew-seconds per floor with their 95 % interval (clipped at 0: ``count_interval``), over
    the episodes whose rows carry ``key`` (``cmdp_pymunk.timeuse``); phase "floor" is the
    phases summed."""
    from cmdp_pymunk.timeuse import CATEGORIES, PHASES

    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        if r.get(key):
            groups.setdefault((r["strategy"], r["navigator"]), []).append(r[key])
    out = []
    for (strategy, navigator), uses in groups.items():
        for crew_type in sorted({ct for u in uses for ct in u}):
            for phase in ("floor", *PHASES):
                for category in CATEGORIES:
                    values = [sum(u[crew_type][p][category] for p in PHASES) if phase == "floor"
                              else u[crew_type][phase][category] for u in uses if crew_type in u]
                    mean, _, half = mean_ci(values)
                    low, high = count_interval(mean, half)
                    out.append({"strategy": strategy, "navigator": navigator,
                                "crew_type": crew_type, "phase": phase, "category": category,
                                "episodes": len(values), "mean_s": mean, "ci95_low_s": low,
                                "ci95_high_s": high})
    return out


def time_use_table(entries: list[dict]) -> str:
    """``time_use_summary`` as Markdown: crew-hours per floor by category for each strategy and
    crew type, the middle phase's in parentheses (where a scheduler can win time)."""
    from cmdp_pymunk.timeuse import CATEGORIES, CATEGORY_WORDS

    cell = {(e["strategy"], e["navigator"], e["crew_type"], e["phase"], e["category"]):
            e["mean_s"] for e in entries}
    keys = list(dict.fromkeys((e["strategy"], e["navigator"], e["crew_type"]) for e in entries))
    if not keys:
        return ""
    lines = ["## Where the time goes", "",
             "Crew-hours per floor, mean over the episodes (the middle phase, between 10 % and "
             "90 % of the tasks ended, in parentheses):", "",
             "| strategy | low level | crew type | "
             + " | ".join(CATEGORY_WORDS[c] for c in CATEGORIES) + " |",
             "|" + "---|" * (3 + len(CATEGORIES))]
    for strategy, navigator, crew_type in keys:
        values = [f"{cell[(strategy, navigator, crew_type, 'floor', c)] / 3600:.1f} "
                  f"({cell[(strategy, navigator, crew_type, 'middle', c)] / 3600:.1f})"
                  for c in CATEGORIES]
        lines.append(f"| {strategy} | {navigator} | {crew_type} | " + " | ".join(values) + " |")
    return "\n".join(lines) + "\n"


def disruption_means(group: list[dict]) -> dict:
    """Appended to a strategy's summary, so older columns keep their places: per kind of
    disruption the mean count and downtime per episode (``<kind>_count_mean``,
    ``<kind>_downtime_s_mean``; 0 for a case without), then what they cost
    (``training.runs.runner.cost_fields``): the mean delay against the same seeds undisrupted
    with its 95 % interval (``paired``: the seeds where both floors finished), the mean delay
    in %, the mean undisrupted makespan; None where it was not measured."""
    out = {f"{k}_mean": mean_ci([r.get(k, 0) for r in group])[0] for k in STRUCK_FIELDS}
    measured = [r for r in group if r.get("undisrupted_makespan_s") is not None]
    undisrupted = [{"seed": r["seed"], "makespan_s": r["undisrupted_makespan_s"],
                    "finished": True} for r in measured]
    both = paired(group, undisrupted)
    out.update({"disruption_cost_seeds": both["paired_seeds"],
                "disruption_delay_mean_s": both["diff_mean_s"],
                "disruption_delay_ci95_s": both["diff_ci95_s"],
                "disruption_delay_pct_mean": mean_ci([r.get("disruption_delay_pct")
                                                      for r in group])[0],
                "undisrupted_makespan_mean_s": mean_ci([r["undisrupted_makespan_s"]
                                                        for r in measured
                                                        if r["finished"]])[0]})
    return out


def _num(value, digits: int = 0, pm: float | None = None) -> str:
    if value is None:
        return "-"
    text = f"{value:,.{digits}f}"
    return text + (f" ± {pm:,.{digits}f}" if pm is not None else "")


def markdown_table(summary: list[dict], lower_bound_s: float,
                   cpsat: dict | None) -> str:
    """The comparison as Markdown: one row per strategy and low level, then the bounds and the
    stalled or timed-out episodes."""
    # crew-seconds kept from working by disruptions: a column only when a case has them
    disrupted = any(e.get(f"{k}_mean") for e in summary for k in DISRUPTION_IDLE_FIELDS)
    head = ("| strategy | low level | finished | makespan (s), mean ± 95 % CI "
            "| P50 / P80 / P90 (s) "
            "| x lower bound | x seed bound | x CP-SAT bound "
            "| vs priority: diff (s) ± 95 % CI | ratio "
            "| reaching steps | idle: predecessor / task area / no target | crane waits |")
    if disrupted:
        head += " idle: crane breakdown / late delivery / absence / weather |"
    # what the disruptions cost against the same seeds undisrupted: where it was measured
    costed = any(e.get("disruption_cost_seeds") for e in summary)
    if costed:
        head += " disruptions' delay (s) ± 95 % CI |"
    lines = [head, "|" + "---|" * (13 + disrupted + costed)]
    for e in summary:
        ref = e[f"vs_{REFERENCE}_diff_mean_s"]
        vs = "-" if e["strategy"] == REFERENCE or ref is None else \
            _num(ref, 0, e[f"vs_{REFERENCE}_diff_ci95_s"])
        ratio = "-" if e["strategy"] == REFERENCE else _num(e[f"vs_{REFERENCE}_ratio"], 3)
        idle = " / ".join(_num(e[f"{k}_mean"]) for k in (
            "idle_waiting_for_predecessor", "idle_blocked_by_task_area", "idle_no_target"))
        lines.append(
            f"| {e['strategy']} | {e['navigator']} | {e['finished']}/{e['episodes']} | "
            f"{_num(e['makespan_mean_s'], 0, e['makespan_ci95_s'])} | "
            f"{_num(e.get('makespan_p50_s'))} / {_num(e['makespan_p80_s'])} / "
            f"{_num(e.get('makespan_p90_s'))} | "
            f"{_num(e['over_lower_bound'], 2)} | {_num(e.get('over_seed_bound'), 2)} | "
            f"{_num(e['over_cpsat_bound'], 2)} | {vs} | "
            f"{ratio} | {_num(e['reaching_steps_mean'])} | {idle} | "
            f"{_num(e['crane_waits_mean'], 1)} |"
            + (" " + " / ".join(_num(e[f"{k}_mean"]) for k in DISRUPTION_IDLE_FIELDS) + " |"
               if disrupted else "")
            + (f" {_delay(e)} |" if costed else ""))
    lines.append("")
    if costed:
        lines.append("Disruptions' delay: makespan minus the same seed's on the case without "
                     "its disruptions (the same task paces), over the seeds where both "
                     "finished; in % of the undisrupted makespan in brackets.")
    lines.append(f"Lower bound (critical path or per-crew-type work): {lower_bound_s:,.0f} s.")
    bounds = [e["seed_bound_mean_s"] for e in summary if e.get("seed_bound_mean_s")]
    if bounds:
        lines.append(f"Seed bound (per seed, from the paces its floor draws, with loading: "
                     f"the critical path or per-crew-type work; x seed bound is the mean of "
                     f"makespan / it over the finished seeds): mean {bounds[0]:,.0f} s.")
    if cpsat:
        state = "proven optimal" if cpsat["optimal"] else \
            f"not proven optimal in {cpsat['time_limit_s']:g} s; best schedule " \
            f"{_num(cpsat['makespan_s'])} s, gap {_num(100 * (cpsat['gap'] or 0), 1)} %"
        lines.append(f"CP-SAT schedule bound (walking and material lifts left out): "
                     f"{cpsat['bound_s']:,.0f} s ({state}).")
    else:
        lines.append("CP-SAT schedule bound: not solved (ask with the cpsat strategy or "
                     "--cpsat-bound); the bound column is the lower bound above.")
    few = [e["strategy"] for e in summary if e["finished"] < MIN_FLOORS_FOR_PERCENTILES]
    if few:
        lines.append(f"P80/P90 rest on fewer than {MIN_FLOORS_FOR_PERCENTILES} finished floors "
                     f"for {', '.join(dict.fromkeys(few))}: run more seeds before planning on "
                     "them.")
    for e in summary:
        for kind in ("stalled", "timed_out"):
            if e[f"{kind}_seeds"]:
                lines.append(f"{e['strategy']} / {e['navigator']}: {kind.replace('_', ' ')} "
                             f"on seed(s) {', '.join(map(str, e[f'{kind}_seeds']))}.")
    return "\n".join(lines) + "\n"


def _delay(entry: dict) -> str:
    """A strategy's disruption delay for the table: "+2,715 ± 1,020 (8.1 %)"."""
    mean = entry.get("disruption_delay_mean_s")
    if mean is None:
        return "-"
    ci = entry["disruption_delay_ci95_s"]
    pct = entry["disruption_delay_pct_mean"]
    return (f"{mean:+,.0f}" + (f" ± {ci:,.0f}" if ci is not None else "")
            + (f" ({pct:+.1f} %)" if pct is not None else ""))


def csv_text(rows: list[dict], fields: list[str]) -> str:
    """Rows as CSV (numbers as they are, None empty, commas in text quoted)."""
    import csv
    import io

    buf = io.StringIO()
    writer = csv.DictWriter(buf, fields, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for r in rows:
        writer.writerow({k: ("" if r.get(k) is None else
                             ";".join(map(str, r[k])) if isinstance(r.get(k), list) else r[k])
                         for k in fields})
    return buf.getvalue()
