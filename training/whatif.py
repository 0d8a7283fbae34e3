"""A paired what-if for ``cmdp-evaluate``: cases or variants of one case compared on the same
seeds, with makespan and cost side by side (docs/levers.md).

``cmdp-evaluate --case A.toml --case B.toml`` or ``--variant more_rc=crews.RC+1`` plays every
case and variant (``cmdp_pymunk.cases.levers``) with every strategy and low level on the same
seeds and reports, against the first case (the *base*): the paired difference of makespan and
of cost (``cmdp_pymunk.cost``) with its 95 % interval, the difference of cost at doubled crew
rates, each one's P50 and P80, and where the time goes per crew type.

What is paired: a task's pace is drawn from the stream of (seed, task)
(``cmdp_pymunk.streams``), so a task meets the same pace in every variant that has it. What
is not: a changed crew count (or a moved storage) changes who does what and when, so walks,
waits, the crane's queue and the order of tasks differ; the pairing holds the paces, not the
schedule, and two variants' schedules are compared, not matched task by task.

Also here: what ``cmdp-evaluate``'s ordinary run reports of cost (``played_row``,
``money_summary``, ``money_table``).
"""

from __future__ import annotations

from dataclasses import dataclass

from training.runs.runner import EpisodeRunner

PAIRING_NOTE = ("Paired on the seeds: each task meets the same pace in every case and variant "
                "that has it (streams keyed by seed and task). Not paired: a changed crew "
                "count or a moved storage changes who does what and when (walks, waits, the "
                "crane's queue, the order of tasks), so the schedules differ; the differences "
                "are of whole floors on the same paces.")


MONEY_FIELDS = ("crane_lifts", "cost", "cost_crew_rates_x2")  # appended to episodes.csv


def played_row(runner: EpisodeRunner, spec: str, navigator: str, seed: int) -> dict:
    """``runner.run``'s row of one seed with what it cost (``MONEY_FIELDS``: the crane's
    lifts, ``cmdp_pymunk.cost.case_cost`` at the case's rates and at doubled crew rates;
    None for an episode that did not finish)."""
    from agents.models import PolicyStuck
    from cmdp_pymunk.cost import case_cost, crane_lifts
    from training.runs.runner import episode_row

    try:
        engine, episode = runner.play(spec, navigator, seed)
        row = episode_row(engine, episode)
    except PolicyStuck as err:  # as ``EpisodeRunner.run``: the episode counts as stalled
        engine = runner.playing
        row = episode_row(engine, None, str(err))
    lifts = crane_lifts(engine.log.events)
    makespan = row["makespan_s"] if row["finished"] else None
    return {**row, "crane_lifts": lifts, "cost": case_cost(runner.case, makespan, lifts),
            "cost_crew_rates_x2": case_cost(runner.case, makespan, lifts, 2.0)}


def money_summary(group: list[dict], rows: list[dict], entry: dict) -> dict:
    """Appended to a strategy's summary entry: its cost's mean with 95 % interval, P50 and
    P80 over the finished episodes, the mean at doubled crew rates, and the paired
    difference of cost to the priority heuristic on the same seeds (at the case's and at
    doubled crew rates); None where nothing was costed (rows of a run resumed from before)."""
    from training.runs.paired import REFERENCE, mean_ci, paired, percentile

    def as_rows(rs, key):
        return [{"seed": r["seed"], "makespan_s": r.get(key), "finished": r.get(key) is not None}
                for r in rs]

    costs = [r.get("cost") for r in group if r.get("cost") is not None]
    mean, _, ci = mean_ci(costs)
    reference = [r for r in rows if (r["strategy"], r["navigator"])
                 == (REFERENCE, entry["navigator"])]
    out = {"cost_mean": mean, "cost_ci95": ci, "cost_p50": percentile(costs, 50),
           "cost_p80": percentile(costs, 80),
           "cost_crew_rates_x2_mean": mean_ci([r.get("cost_crew_rates_x2") for r in group])[0]}
    for key, name in (("cost", "cost"), ("cost_crew_rates_x2", "cost_crew_rates_x2")):
        both = paired(as_rows(group, key), as_rows(reference, key))
        out[f"vs_{REFERENCE}_{name}_diff_mean"] = both["diff_mean_s"]
        out[f"vs_{REFERENCE}_{name}_diff_ci95"] = both["diff_ci95_s"]
    return out


def money_table(summary: list[dict], case) -> str:
    """summary.md's cost beside the makespan: one row per strategy and low level."""
    from cmdp_pymunk.cost import cost_model
    from training.runs.paired import REFERENCE

    def num(v, pm=None):
        return "-" if v is None else f"{v:,.0f}" + (f" ± {pm:,.0f}" if pm is not None else "")

    currency = cost_model(case).currency
    lines = [f"## Cost ({currency})", "",
             "| strategy | low level | makespan P50 / P80 (s) | cost, mean ± 95 % CI "
             "| cost P50 / P80 | vs priority: cost diff ± 95 % CI | the same at crew rates x 2 |",
             "|---|---|---|---|---|---|---|"]
    for e in summary:
        ref = e["strategy"] == REFERENCE
        lines.append(
            f"| {e['strategy']} | {e['navigator']} | {num(e.get('makespan_p50_s'))} / "
            f"{num(e.get('makespan_p80_s'))} | {num(e['cost_mean'], e['cost_ci95'])} | "
            f"{num(e['cost_p50'])} / {num(e['cost_p80'])} | "
            + ("-" if ref else num(e[f"vs_{REFERENCE}_cost_diff_mean"],
                                   e[f"vs_{REFERENCE}_cost_diff_ci95"])) + " | "
            + ("-" if ref else num(e[f"vs_{REFERENCE}_cost_crew_rates_x2_diff_mean"],
                                   e[f"vs_{REFERENCE}_cost_crew_rates_x2_diff_ci95"])) + " |")
    lines += ["", cost_note(case)]
    return "\n".join(lines) + "\n"


def cost_note(case) -> str:
    """Where a table's rates come from: the case's ``[cost]`` or the assumed defaults."""
    from cmdp_pymunk.cost import cost_model

    c = cost_model(case)
    where = "the case's [cost]" if case.cost is not None else \
        "the default rates, assumptions (docs/levers.md): give the site's own in [cost]"
    return (f"Cost: every crew paid for the whole makespan, the crane hired and the site's "
            f"overhead run until it ends ({where}: crews {c.default_crew_rate_per_h:g}/h "
            f"unless named, crane {c.crane_per_h:g}/h + {c.crane_per_lift:g}/lift, overhead "
            f"{c.overhead_per_h:g}/h"
            + (f", {c.penalty_per_day:g}/day past {c.due_s:g} s" if c.due_s else "")
            + "); cmdp_pymunk.cost.run_cost.")




# -- the what-if ----------------------------------------------------------------------------

@dataclass(frozen=True)
class Entry:
    """One case or variant of a what-if: its ``name`` (the variant's, or the case's), its
    ``changes`` against the base (``""`` for a case file), the validated ``case``, where it
    came from (``source``: a file, or the variant's ``--variant``) and its floor
    (``training.fidelity.Floor``)."""

    name: str
    changes: str
    case: object
    source: str
    floor: object


_RUNNERS: dict[str, EpisodeRunner] = {}  # per worker process: one runner per entry


def whatif_job(_runner, name: str, case_data: dict, runner_args: tuple, spec: str,
               navigator: str, seed: int) -> dict:
    """One episode of one entry (``played_row``), in a worker whose runners are made per entry
    when first asked (``runner_args``: ``EpisodeRunner``'s arguments after the case)."""
    if name not in _RUNNERS:
        from cmdp_pymunk.cases.load import case_from_dict

        _RUNNERS[name] = EpisodeRunner(case_from_dict(case_data, name), *runner_args)
    return played_row(_RUNNERS[name], spec, navigator, seed)


def crew_counts(case) -> str:
    """``RC 3, FC 2, ...``: the crews per type, as the table shows them."""
    from cmdp_pymunk.cost import crews_by_type

    return ", ".join(f"{t} {n}" for t, n in crews_by_type(case).items())


def whatif_summary(rows: list[dict], entries: list[Entry]) -> list[dict]:
    """One entry per (case or variant, strategy, low level), in that order: the makespan's
    and the cost's mean with 95 % interval, P50 and P80 over the finished episodes, and
    against the base (the first entry) with the same strategy and low level on the seeds
    both finished: the paired differences of makespan, cost and cost at doubled crew rates
    with their 95 % intervals (``training.runs.paired.paired``) and the ratio of mean
    makespans."""
    from cmdp_pymunk.bounds import lower_bound
    from training.runs.paired import mean_ci, paired, percentile

    def as_rows(rs, key):
        return [{"seed": r["seed"], "makespan_s": r.get(key),
                 "finished": r["finished"] and r.get(key) is not None} for r in rs]

    base = entries[0].name
    groups: dict[tuple[str, str, str], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["variant"], r["strategy"], r["navigator"]), []).append(r)
    by_name = {e.name: e for e in entries}
    out = []
    for (variant, strategy, navigator), group in groups.items():
        entry = by_name[variant]
        reference = groups.get((base, strategy, navigator), [])
        finished = [r["makespan_s"] for r in group if r["finished"]]
        costs = [r["cost"] for r in group if r["finished"] and r.get("cost") is not None]
        mean, _, ci = mean_ci(finished)
        cost_mean, _, cost_ci = mean_ci(costs)
        e = {"variant": variant, "changes": entry.changes, "source": entry.source,
             "crews": crew_counts(entry.case), "strategy": strategy, "navigator": navigator,
             "episodes": len(group), "finished": len(finished),
             "lower_bound_s": lower_bound(entry.case).lower_bound_s,
             "makespan_mean_s": mean, "makespan_ci95_s": ci,
             "makespan_p50_s": percentile(finished, 50), "makespan_p80_s": percentile(finished, 80),
             "cost_mean": cost_mean, "cost_ci95": cost_ci, "cost_p50": percentile(costs, 50),
             "cost_p80": percentile(costs, 80)}
        time = paired(as_rows(group, "makespan_s"), as_rows(reference, "makespan_s"))
        e.update({"vs_base_paired_seeds": time["paired_seeds"],
                  "vs_base_makespan_diff_mean_s": time["diff_mean_s"],
                  "vs_base_makespan_diff_ci95_s": time["diff_ci95_s"],
                  "vs_base_makespan_ratio": time["ratio"]})
        for key in ("cost", "cost_crew_rates_x2"):
            both = paired(as_rows(group, key), as_rows(reference, key))
            e[f"vs_base_{key}_diff_mean"] = both["diff_mean_s"]
            e[f"vs_base_{key}_diff_ci95"] = both["diff_ci95_s"]
        out.append(e)
    return out


def _num(value, digits: int = 0, pm: float | None = None, sign: bool = False) -> str:
    if value is None:
        return "-"
    text = f"{value:+,.{digits}f}" if sign else f"{value:,.{digits}f}"
    return text + (f" ± {pm:,.{digits}f}" if pm is not None else "")


def whatif_table(summary: list[dict], entries: list[Entry], notes: list[str]) -> str:
    """whatif.md: one row per case or variant, strategy and low level, then the notes (the
    base, the pairing, the cost model, the floor)."""
    from cmdp_pymunk.cost import cost_model

    base = entries[0]
    currency = cost_model(base.case).currency
    lines = [f"# What-if against {base.name!r}", "",
             f"| case or variant | changes | crews | strategy | low level | finished "
             f"| makespan (s), mean ± 95 % CI | P50 / P80 (s) | cost ({currency}), mean ± 95 % CI "
             f"| cost P50 / P80 | vs base: makespan diff (s) ± 95 % CI | ratio "
             f"| vs base: cost diff ± 95 % CI | the same at crew rates x 2 |",
             "|" + "---|" * 14]
    for e in summary:
        is_base = e["variant"] == base.name
        lines.append(
            f"| {e['variant']} | {e['changes'] or '-'} | {e['crews']} | {e['strategy']} | "
            f"{e['navigator']} | {e['finished']}/{e['episodes']} | "
            f"{_num(e['makespan_mean_s'], 0, e['makespan_ci95_s'])} | "
            f"{_num(e['makespan_p50_s'])} / {_num(e['makespan_p80_s'])} | "
            f"{_num(e['cost_mean'], 0, e['cost_ci95'])} | "
            f"{_num(e['cost_p50'])} / {_num(e['cost_p80'])} | "
            + (" - | - | - | - |" if is_base else " | ".join((
                _num(e["vs_base_makespan_diff_mean_s"], 0, e["vs_base_makespan_diff_ci95_s"],
                     True),
                _num(e["vs_base_makespan_ratio"], 3),
                _num(e["vs_base_cost_diff_mean"], 0, e["vs_base_cost_diff_ci95"], True),
                _num(e["vs_base_cost_crew_rates_x2_diff_mean"], 0,
                     e["vs_base_cost_crew_rates_x2_diff_ci95"], True))) + " |"))
    lines.append("")
    lines += [f"Differences: each row minus {base.name!r} with the same strategy and low "
              "level, on the seeds both finished (mean of the per-seed differences, Student's t).",
              PAIRING_NOTE, *notes]
    return "\n".join(lines) + "\n"
