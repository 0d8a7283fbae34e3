"""A plan search's confirmation (``training.search.plan_search``, module doc): the best plans of
the search and the case as written on the held-out confirmation seeds (by default on the pymunk
floor), each paired with the case, the plan chosen (``confirm_plans``), and what each change of
it is worth alone and all together (``levers_rows``: levers.md's rows).

Apart from the search on the event floor because it is the second stage of a search, on other
seeds and another floor: it asks the study nothing new and only reads its trials, then plays
floors through the search's ``SearchRun`` (the one way plans are made and floors played).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from cmdp_pymunk.cases.levers import label_of

from .plan_scores import _against, feasible, rank_key, scores, within_bound
from .plan_space import BASE_LABEL, _changes_of

if TYPE_CHECKING:  # an annotation only: the search imports this module
    from .plan_search import SearchRun


@dataclass
class Confirmation:
    """What the confirmation on the held-out seeds found (module doc): the study's trials and
    its complete ones, each plan's first complete scores on the search seeds and the case's,
    the Pareto front's plans (``pareto``), the plans confirmed, the case's held-out rows and
    scores, each confirmed plan against the case, and the plan chosen."""

    trials: list
    complete: list
    best_by_plan: dict[str, dict]
    base_search: dict
    front: set[str]
    confirmed: list[str]
    base_rows: list[dict]
    base_held: dict
    held: dict[str, dict]
    chosen_label: str


def confirm_plans(run: SearchRun) -> Confirmation:
    """The best ``confirm`` plans of the search (the feasible ones; for ``pareto`` the front's)
    and the case as written on the held-out seeds, and the plan chosen: the confirmed plan best
    by the objective that finished every floor, beat the case and kept the cost bound, else
    the case (module doc)."""
    from optuna.trial import TrialState

    case, config, study, floors_ = run.case, run.config, run.study, run.floors
    trials = study.get_trials(deepcopy=False)
    complete = [t for t in trials if t.state == TrialState.COMPLETE]
    best_by_plan: dict[str, dict] = {}
    for t in complete:
        best_by_plan.setdefault(t.user_attrs["plan"], t.user_attrs["scores"])
    base_search = best_by_plan.get(BASE_LABEL) or scores(
        floors_.of("event", BASE_LABEL, config.search_seeds))
    key = rank_key(config.objective, base_search)
    within = {t.user_attrs["plan"] for t in complete if feasible(t)}
    if config.objective == "pareto":
        # best_trials keeps the feasible trials only when the study has constraints
        front = {t.user_attrs["plan"] for t in study.best_trials}
        pool_plans = [p for p in best_by_plan if p in front]
    else:
        front = set()
        # as study.best_trial: a constrained search confirms feasible plans only
        pool_plans = [p for p in best_by_plan if p in within]
    ranked = sorted((p for p in pool_plans if p != BASE_LABEL),
                    key=lambda p: (key(best_by_plan[p]), p))
    confirmed = ranked[:config.confirm]
    cf = config.confirm_fidelity
    wanted = [(p, run.variant_of(_changes_of(case, p))[1], s)
              for p in [BASE_LABEL, *confirmed] for s in config.confirm_seeds]
    run.bar.total -= (config.confirm - len(confirmed)) * run.n_confirm
    floors_.play(cf, wanted)
    base_rows = floors_.of(cf, BASE_LABEL, config.confirm_seeds)
    base_held = scores(base_rows)
    held = {p: _against(floors_.of(cf, p, config.confirm_seeds), base_rows)
            for p in confirmed}
    hkey = rank_key(config.objective, base_held)
    if config.constrained:
        for p in confirmed:
            held[p]["within_cost_bound"] = within_bound(held[p], base_held,
                                                        config.max_cost_ratio)
    better = [p for p in confirmed if held[p]["finished"] == held[p]["floors"]
              and hkey(held[p]) < hkey(base_held)
              and held[p].get("within_cost_bound", True)]
    chosen_label = min(better, key=lambda p: (hkey(held[p]), p)) if better else BASE_LABEL
    return Confirmation(trials, complete, best_by_plan, base_search, front, confirmed,
                        base_rows, base_held, held, chosen_label)


def levers_rows(run: SearchRun, confirmation: Confirmation) -> tuple[str, list[dict]]:
    """What each change of the chosen plan (else the best confirmed one) is worth alone and
    all together, against the case on the held-out seeds: the plan's label and levers.md's
    rows."""
    config, floors_, base_rows = run.config, run.floors, confirmation.base_rows
    cf = config.confirm_fidelity
    chosen_label, confirmed = confirmation.chosen_label, confirmation.confirmed
    table_label = chosen_label if chosen_label != BASE_LABEL else \
        (confirmed[0] if confirmed else BASE_LABEL)
    changes = _changes_of(run.case, table_label)
    alone = [(c.label, (c,)) for c in changes] if len(changes) > 1 and config.alone \
        else []
    run.bar.total -= (len(run.space) - len(alone)) * run.n_confirm
    floors_.play(cf, [(label_of(ch), run.variant_of(ch)[1], s) for _, ch in alone
                      for s in config.confirm_seeds])
    lever_rows = [{"lever": "as the case", **_against(base_rows, base_rows)}]
    for name, ch in alone:
        lever_rows.append({"lever": name, **_against(
            floors_.of(cf, label_of(ch), config.confirm_seeds), base_rows)})
    if changes:
        lever_rows.append({"lever": "together: " + table_label, **_against(
            floors_.of(cf, table_label, config.confirm_seeds), base_rows)})
    return table_label, lever_rows
