"""What a plan scores (``training.search.plan_search``): its numbers over the floors it played
(``scores``), the study's values of them (``objective_values``), the cost bound on the search
seeds (``cost_bound``, ``feasible``), the order plans are ranked and chosen in (``rank_key``,
``balance``), and a confirmed plan against the case on the held-out seeds (``_against``,
``within_bound``).

Apart from the search because these are pure functions of rows of played floors (the paired
statistics of ``training.runs.paired``): each can be checked by hand, with no floor or study.
"""

from __future__ import annotations

import math

from ..runs.paired import mean_ci, paired, percentile


def scores(rows: list[dict]) -> dict:
    """A plan's numbers over its rows: P80, P50 and mean makespan (finished floors), mean and
    P80 cost, floors played and finished."""
    finished = [r["makespan_s"] for r in rows if r["finished"]]
    costs = [r["cost"] for r in rows if r["finished"] and r.get("cost") is not None]
    return {"floors": len(rows), "finished": len(finished),
            "p80_s": percentile(finished, 80), "p50_s": percentile(finished, 50),
            "mean_s": mean_ci(finished)[0], "cost_mean": mean_ci(costs)[0],
            "cost_p80": percentile(costs, 80)}


def objective_values(objective: str, s: dict) -> list[float] | None:
    """The study's values of a plan's scores; None when a floor did not finish (the plan
    fails: a stalled or timed-out floor has no makespan to rank)."""
    if s["finished"] < s["floors"] or s["floors"] == 0:
        return None
    return {"p80": [s["p80_s"]], "cost": [s["cost_mean"]],
            "pareto": [s["p80_s"], s["cost_mean"]]}[objective]


def _cost_rows(rows: list[dict], key: str = "cost") -> list[dict]:
    """Rows with ``key`` in the makespan's place, for ``paired`` (a run without it unfinished)."""
    return [{"seed": r["seed"], "makespan_s": r.get(key),
             "finished": r["finished"] and r.get(key) is not None} for r in rows]


def cost_bound(rows: list[dict], base_rows: list[dict], max_cost_ratio: float) -> dict:
    """A plan against the cost bound (module doc), paired with the case on the seeds both
    finished: ``cost_ratio`` (the plan's mean cost over the case's), ``cost_violation``
    (``cost_ratio - max_cost_ratio``: Optuna's constraint value, feasible at 0 or less) and
    ``clearly_over`` (the paired cost difference's 95 % interval lies wholly above the
    bound's allowance ``(max_cost_ratio - 1) x`` the case's mean cost: pruned as infeasible
    before its last rung)."""
    d = paired(_cost_rows(rows), _cost_rows(base_rows))
    if not d["paired_seeds"]:
        return {"cost_ratio": None, "cost_violation": None, "clearly_over": False}
    base = {r["seed"]: r["cost"] for r in base_rows if r["finished"] and r.get("cost") is not None}
    seeds = {r["seed"] for r in rows if r["finished"] and r.get("cost") is not None} & set(base)
    allowance = (max_cost_ratio - 1.0) * sum(base[s] for s in seeds) / len(seeds)
    low = d["diff_mean_s"] - (d["diff_ci95_s"] if d["diff_ci95_s"] is not None else math.inf)
    return {"cost_ratio": d["ratio"], "cost_violation": d["ratio"] - max_cost_ratio,
            "clearly_over": low > allowance}


def feasible(trial) -> bool:
    """A told trial within every constraint it carries (Optuna's rule: each value <= 0)."""
    return all(v <= 0.0 for v in trial.constraints.values())


def balance(s: dict, base: dict) -> float:
    """A plan's P80 and mean cost each over the case's, summed: the plan of a Pareto front
    chosen (the lowest; the case scores 2)."""
    return s["p80_s"] / base["p80_s"] + s["cost_mean"] / base["cost_mean"]


def rank_key(objective: str, base: dict | None):
    def key(s: dict) -> float:
        if objective == "p80":
            return s["p80_s"]
        if objective == "cost":
            return s["cost_mean"]
        return balance(s, base)
    return key


def _against(rows: list[dict], base_rows: list[dict]) -> dict:
    """A plan's scores on the held-out seeds and, paired with the case on the seeds both
    finished, its makespan, cost and cost-at-doubled-crew-rates differences with 95 %
    intervals (``training.runs.paired``)."""
    s = scores(rows)
    diff = paired(rows, base_rows)
    base = scores(base_rows)
    out = {**s, "paired_seeds": diff["paired_seeds"], "makespan_diff_mean_s": diff["diff_mean_s"],
           "makespan_diff_ci95_s": diff["diff_ci95_s"], "makespan_ratio": diff["ratio"],
           "p80_ratio": (s["p80_s"] / base["p80_s"]
                         if s["p80_s"] is not None and base["p80_s"] else None)}
    for key in ("cost", "cost_crew_rates_x2"):
        d = paired(_cost_rows(rows, key), _cost_rows(base_rows, key))
        out[f"{key}_diff_mean"], out[f"{key}_diff_ci95"] = d["diff_mean_s"], d["diff_ci95_s"]
        out[f"{key}_ratio"] = d["ratio"]
    return out


def within_bound(held: dict, base: dict, max_cost_ratio: float) -> bool:
    """Whether a confirmed plan keeps the cost bound on the held-out seeds: its paired mean cost
    difference to the case at most ``(max_cost_ratio - 1) x`` the case's mean cost (at 1.0:
    the paired difference at most 0)."""
    d = held.get("cost_diff_mean")
    return d is not None and d <= (max_cost_ratio - 1.0) * base["cost_mean"] + 1e-9
