"""What a floor costs beside how long it takes (beyond the paper; docs/levers.md).

The paper's objective is the makespan alone. A search over the site's levers that sees only
time would simply add crews (one more reinforcing crew took the built-in floor to 0.943 x its
makespan, issue 42), so every comparison of variants reports cost beside time:

    cost = T_h * (sum over crews of rate(type) + crane_per_h + overhead_per_h)
           + lifts * crane_per_lift
           + penalty_per_day * max(0, T - due_s) / day_s

with ``T`` the makespan in seconds and ``T_h`` in hours: every crew is paid, the crane hired
and the site's time-related overhead run from the floor's start to its end. The rates are a
case's ``[cost]`` section (``cases.model.Cost``); a case without one is costed at the stated
defaults, which are assumptions (docs/levers.md), so a difference of cost between variants
means more than its level.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping

from .cases.model import Case, Cost
from .events import Event

__all__ = ["Cost", "cost_model", "crews_by_type", "crane_lifts", "run_cost", "case_cost",
           "with_crew_rates_scaled", "run_cost_fields", "cost_percentiles"]


def cost_model(case: Case) -> Cost:
    """The case's ``[cost]``, or the default (assumed) rates when it has none."""
    return case.cost if case.cost is not None else Cost()


def crews_by_type(case: Case) -> dict[str, int]:
    """How many crews of each type the case has, in the order the types first appear."""
    return dict(Counter(crew.type for crew in case.crews))


def crane_lifts(events: Iterable[Event]) -> int:
    """The crane's completed services in an event log: each material lift and each hoisting
    assistance (``crane_done``), what ``crane_per_lift`` is charged on."""
    return sum(1 for e in events if e.kind == "crane_done")


def run_cost(makespan_s: float, crews: Mapping[str, int], lifts: int, cost: Cost) -> float:
    """A run's cost (module doc; not in the paper):
    ``T_h * (sum_c rate(c) + crane_per_h + overhead_per_h) + lifts * crane_per_lift
    + penalty_per_day * max(0, T - due_s) / day_s``.

    Args:
        makespan_s: the run's makespan T, simulated seconds.
        crews: crews per crew type (each paid for the whole makespan).
        lifts: the crane's completed services (``crane_lifts``).
        cost: the rates (``cost_model``).
    """
    hours = makespan_s / 3600.0
    per_hour = (sum(n * cost.crew_rate(crew_type) for crew_type, n in crews.items())
                + cost.crane_per_h + cost.overhead_per_h)
    late_days = max(0.0, makespan_s - cost.due_s) / cost.day_s if cost.due_s is not None else 0.0
    return hours * per_hour + lifts * cost.crane_per_lift + late_days * cost.penalty_per_day


def with_crew_rates_scaled(cost: Cost, factor: float) -> Cost:
    """The same rates with every crew rate times ``factor`` (a plan's advantage is also
    reported at doubled crew rates: does it hold when labour costs more?)."""
    return cost.model_copy(update={
        "crew_rate_per_h": {k: v * factor for k, v in cost.crew_rate_per_h.items()},
        "default_crew_rate_per_h": cost.default_crew_rate_per_h * factor})


def case_cost(case: Case, makespan_s: float | None, lifts: int,
              crew_rate_factor: float = 1.0) -> float | None:
    """``run_cost`` of one run of ``case`` (None for a run that did not finish)."""
    if makespan_s is None:
        return None
    cost = cost_model(case)
    if crew_rate_factor != 1.0:
        cost = with_crew_rates_scaled(cost, crew_rate_factor)
    return run_cost(makespan_s, crews_by_type(case), lifts, cost)



def run_cost_fields(case: Case, makespan_s: float | None, events: Iterable[Event]) -> dict:
    """What one run of ``case`` cost, as a summary reports it: ``crane_lifts`` (in
    ``events``), ``cost`` at the case's rates and ``cost_crew_rates_x2`` at doubled crew rates
    (``case_cost``; None for a run that did not finish, ``makespan_s`` None)."""
    lifts = crane_lifts(events)
    return {"crane_lifts": lifts, "cost": case_cost(case, makespan_s, lifts),
            "cost_crew_rates_x2": case_cost(case, makespan_s, lifts, 2.0)}


def cost_percentiles(runs: Iterable[Mapping]) -> dict:
    """Over several runs' ``run_cost_fields`` (runs without a cost left out): the cost's mean,
    P50 and P80 (``numpy.percentile``, linear, as the makespan's), the mean at doubled crew
    rates and how many runs were costed; None for each without any."""
    import numpy as np

    runs = list(runs)
    costs = [r["cost"] for r in runs if r.get("cost") is not None]
    doubled = [r["cost_crew_rates_x2"] for r in runs if r.get("cost_crew_rates_x2") is not None]
    return {"cost_runs": len(costs),
            "cost_mean": float(np.mean(costs)) if costs else None,
            "cost_p50": float(np.percentile(costs, 50)) if costs else None,
            "cost_p80": float(np.percentile(costs, 80)) if costs else None,
            "cost_crew_rates_x2_mean": float(np.mean(doubled)) if doubled else None}
