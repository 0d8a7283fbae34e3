"""A plan search's outputs (``training.search.plan_search``; docs/levers.md): ``levers.md`` and
``levers.csv`` (what each change of the plan is worth alone and together: ``levers_table``,
``LEVER_FIELDS``), ``trials.csv`` (every trial of the study: ``trial_rows``, ``TRIAL_FIELDS``),
and ``write_outputs``, which writes them with ``plan.toml``, ``plans/``, ``media/pareto.png``
and ``summary.json``, each whole.

Apart from the search because it reads only what a search left (its summary, its study, the
case) and writes files: the search plays no floor for it, and it changes nothing the search
decides.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

from cmdp_pymunk.cases.levers import make_variant, variant_toml
from cmdp_pymunk.cases.model import Case
from cmdp_pymunk.events import write_atomic

from .plan_space import BASE_LABEL, _changes_of
from .plan_study import study_storage

if TYPE_CHECKING:  # an annotation only: the search imports this module
    from .plan_search import PlanResult


def _num(v, digits: int = 0, pm=None, sign: bool = False) -> str:
    if v is None:
        return "-"
    text = f"{v:+,.{digits}f}" if sign else f"{v:,.{digits}f}"
    return text + (f" ± {pm:,.{digits}f}" if pm is not None else "")


def levers_table(summary: dict, currency: str) -> str:
    """levers.md: what each change of the plan is worth alone and all together, against the
    case as written on the held-out seeds (paired)."""
    t, c = summary["levers_table"], summary["confirmation"]
    lines = [f"# What each lever is worth: {t['plan']}", "",
             f"On the {c['floor']} floor, held-out seeds {c['seeds'][0]}-{c['seeds'][-1]} "
             f"({len(c['seeds'])}), {summary['settings']['evaluator']} + scripted; differences "
             "are paired with the case as written on the seeds both finished (mean of the "
             "per-seed differences, Student's t 95 %).", "",
             "| lever | finished | makespan mean (s) | P80 (s) | vs case: makespan diff (s) "
             f"| ratio | cost mean ({currency}) | vs case: cost diff "
             "| the same at crew rates x 2 |",
             "|" + "---|" * 9]
    for r in t["rows"]:
        base = r["lever"] == "as the case"
        lines.append(
            f"| {r['lever']} | {r['finished']}/{r['floors']} | {_num(r['mean_s'])} | "
            f"{_num(r['p80_s'])} | "
            + ("- | - | " if base else
               f"{_num(r['makespan_diff_mean_s'], 0, r['makespan_diff_ci95_s'], True)} | "
               f"{_num(r['makespan_ratio'], 3)} | ")
            + f"{_num(r['cost_mean'])} | "
            + ("- | - |" if base else
               f"{_num(r['cost_diff_mean'], 0, r['cost_diff_ci95'], True)} | "
               + _num(r["cost_crew_rates_x2_diff_mean"], 0, r["cost_crew_rates_x2_diff_ci95"],
                      True) + " |"))
    if len(t["rows"]) > 2:
        alone = [r["makespan_diff_mean_s"] for r in t["rows"][1:-1]]
        if None not in alone and t["rows"][-1]["makespan_diff_mean_s"] is not None:
            lines += ["", f"The changes alone sum to {sum(alone):+,.0f} s; together they make "
                      f"{t['rows'][-1]['makespan_diff_mean_s']:+,.0f} s (the difference is how "
                      "they interact)."]
    return "\n".join(lines) + "\n"


LEVER_FIELDS = ("lever", "floors", "finished", "mean_s", "p50_s", "p80_s", "cost_mean",
                "cost_p80", "paired_seeds", "makespan_diff_mean_s", "makespan_diff_ci95_s",
                "makespan_ratio", "cost_diff_mean", "cost_diff_ci95",
                "cost_crew_rates_x2_diff_mean", "cost_crew_rates_x2_diff_ci95")
TRIAL_FIELDS = ("number", "state", "plan", "floors", "finished", "p80_s", "mean_s",
                "cost_mean", "note", "cost_ratio", "feasible")  # the last two: --max-cost-ratio


def write_outputs(result: PlanResult, case: Case, study_rows: list[dict], out: Path) -> list[Path]:
    """plan.toml, plans/NAME.toml (each confirmed plan), levers.md, levers.csv, trials.csv,
    media/pareto.png and summary.json into ``out``, each written whole."""
    from cmdp_pymunk.cost import cost_model
    from media.pareto import draw_pareto

    from ..runs.paired import csv_text

    s = result.summary
    currency = cost_model(case).currency
    files = []
    chosen = s["chosen"]
    note = (f"Plan chosen by cmdp-plan ({s['objective']}) on {s['tried']['trials']} plans "
            f"tried; confirmed on the {s['confirmation']['floor']} floor, held-out seeds "
            f"{s['confirmation']['seeds'][0]}-{s['confirmation']['seeds'][-1]}"
            + (f"; {chosen['note']}" if chosen["note"] else ""))
    write_atomic(out / "plan.toml", variant_toml(result.chosen, note))
    files.append(out / "plan.toml")
    for i, p in enumerate(s["confirmation"]["plans"], 1):
        v = make_variant(case, _changes_of(case, p["plan"]), f"plan{i}")
        write_atomic(out / "plans" / f"plan{i}.toml",
                     variant_toml(v, f"cmdp-plan: confirmed plan {i} of "
                                  f"{len(s['confirmation']['plans'])}"))
        files.append(out / "plans" / f"plan{i}.toml")
    write_atomic(out / "levers.md", levers_table(s, currency))
    write_atomic(out / "levers.csv", csv_text(s["levers_table"]["rows"], list(LEVER_FIELDS)))
    write_atomic(out / "trials.csv", csv_text(study_rows, list(TRIAL_FIELDS)))
    files += [out / "levers.md", out / "levers.csv", out / "trials.csv"]
    files.append(draw_pareto(s["points"], out / "media" / "pareto.png", BASE_LABEL,
                             chosen["plan"], currency,
                             f"{s['case']}: {len(s['points'])} plans on "
                             f"{len(s['search']['seeds'])} search seeds (event floor)"))
    write_atomic(out / "summary.json", json.dumps(s, indent=1, default=str) + "\n")
    files.append(out / "summary.json")
    return files


def trial_rows(out: Path) -> list[dict]:
    """trials.csv's rows: every trial of the study in ``out``, its state, plan and scores."""
    import optuna

    study = optuna.load_study(study_name="plan", storage=study_storage(out))
    rows = []
    for t in study.get_trials(deepcopy=False):
        sc = t.user_attrs.get("scores", {})
        rows.append({"number": t.number, "state": t.state.name, "plan": t.user_attrs.get("plan"),
                     **{k: sc.get(k) for k in ("floors", "finished", "p80_s", "mean_s",
                                               "cost_mean", "cost_ratio")},
                     "feasible": (all(v <= 0.0 for v in t.constraints.values())
                                  if t.constraints else None),
                     "note": t.user_attrs.get("invalid", "") or
                     ("a floor did not finish" if t.user_attrs.get("unfinished") else "") or
                     (f"over the cost bound at {t.user_attrs['over_cost_at']} seeds"
                      if t.user_attrs.get("over_cost_at") else "")})
    return rows
