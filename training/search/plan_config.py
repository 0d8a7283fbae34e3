"""A plan search's settings (``training.search.plan_search``; ``cmdp-plan``'s options,
docs/levers.md): ``PlanConfig`` with its checks (``problems``), the pruner's rungs and what a
resumed search must share (``fingerprint``), and the choices it checks against (``OBJECTIVES``,
``SAMPLERS``, ``SCREENS``).

Apart from the search because the command parses its options into it before anything runs,
and the study, the floors and the outputs each read it: a dataclass of plain values that
imports nothing of the search.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass

OBJECTIVES = ("p80", "cost", "pareto")
# the samplers a search may pick plans with (``--sampler``; ``plan_study.make_sampler``)
SAMPLERS = ("tpe-joint", "tpe-independent", "nsga2", "random")
STARTUP_TRIALS = 8  # TPE's random start-up trials before it models the plans (the default)
SCREENS = ("crew-pairs", "none")  # the plans tried first, after the case (``--screen``)
STALL_S = 3600.0


@dataclass(frozen=True)
class PlanConfig:
    """A plan search's settings (``cmdp-plan``'s options; docs/levers.md)."""

    objective: str = "p80"
    trials: int = 40  # plans tried, the case as written first (the budget)
    search_seeds: tuple[int, ...] = tuple(range(1000, 1016))
    confirm_seeds: tuple[int, ...] = tuple(range(2000, 2020))
    min_seeds: int = 4  # the pruner's first rung: every plan plays this many search seeds
    reduction_factor: int = 2  # a rung keeps the best 1/reduction_factor of the plans
    batch: int = 4  # trials asked together (their floors run on the backend at once)
    confirm: int = 3  # the best plans confirmed on the held-out seeds
    confirm_fidelity: str = "pymunk"
    evaluator: str = "priority"
    seed: int = 0  # the sampler's
    stall_s: float = STALL_S
    max_cost_ratio: float | None = None  # p80/pareto: mean cost at most this x the case's
    alone: bool = True  # measure each change of the chosen plan alone (levers.md)
    sampler: str | None = None  # SAMPLERS; None: tpe-joint for p80/cost, nsga2 for pareto
    startup_trials: int = STARTUP_TRIALS  # TPE's random start-up trials
    screen: str = "crew-pairs"  # SCREENS: the plans tried first (``crew_screen``)

    @property
    def sampler_name(self) -> str:
        """The sampler this search uses: ``sampler``, or the objective's default."""
        if self.sampler is not None:
            return self.sampler
        return "nsga2" if self.objective == "pareto" else "tpe-joint"

    @property
    def constrained(self) -> bool:
        return self.max_cost_ratio is not None

    def problems(self) -> list[str]:
        """Every bad setting, with its fix."""
        out = []
        if self.objective not in OBJECTIVES:
            out.append(f"--objective {self.objective!r} is not one of {', '.join(OBJECTIVES)}; "
                       "fix: p80 (the lowest P80 makespan), cost or pareto")
        both = sorted(set(self.search_seeds) & set(self.confirm_seeds))
        if both:
            out.append(f"--search-seeds and --confirm-seeds share seeds {both[:5]}; fix: the "
                       "plans are confirmed on seeds the search never saw (e.g. "
                       "--search-seeds 1000-1015 --confirm-seeds 2000-2019)")
        if len(self.confirm_seeds) < 2:
            out.append("--confirm-seeds gives fewer than 2 seeds; fix: give 20 or more for a "
                       "paired interval that means something")
        if self.min_seeds > len(self.search_seeds):
            out.append(f"--min-seeds {self.min_seeds} is more than the {len(self.search_seeds)} "
                       "search seeds; fix: lower it, or give more --search-seeds")
        if self.sampler is not None and self.sampler not in SAMPLERS:
            out.append(f"--sampler {self.sampler!r} is not one of {', '.join(SAMPLERS)}; fix: "
                       "tpe-joint (TPE modelling the levers together, the default for p80 and "
                       "cost), tpe-independent (each lever on its own), nsga2 or random")
        if self.screen not in SCREENS:
            out.append(f"--screen {self.screen!r} is not one of {', '.join(SCREENS)}; fix: "
                       "crew-pairs (each crew type one fewer or more, and every two types one "
                       "more each, tried first) or none")
        if self.startup_trials < 1:
            out.append(f"--startup-trials {self.startup_trials} is below 1; fix: give the "
                       f"random plans TPE tries before it models them, e.g. {STARTUP_TRIALS}")
        if self.reduction_factor < 2:
            out.append("--reduction-factor must be at least 2; fix: give 2 or 3")
        if self.constrained:
            if not (math.isfinite(self.max_cost_ratio) and self.max_cost_ratio > 0):
                out.append(f"--max-cost-ratio {self.max_cost_ratio} is not a positive number; "
                           "fix: give the mean cost a plan may reach over the case's, e.g. 1.0 "
                           "(no dearer than the case)")
            if self.objective == "cost":
                out.append("--max-cost-ratio bounds the cost of a search on time; with "
                           "--objective cost the cost is already what is minimised; fix: "
                           "--objective p80 --max-cost-ratio 1.0, or drop --max-cost-ratio")
        return out

    def rungs(self) -> list[int]:
        """How many search seeds a plan has played at each check of the pruner: min_seeds,
        then times reduction_factor, up to every search seed; only the last for ``pareto``."""
        n = len(self.search_seeds)
        if self.objective == "pareto":
            return [n]
        out, k = [], self.min_seeds
        while k < n:
            out.append(k)
            k *= self.reduction_factor
        return out + [n]

    def fingerprint(self) -> dict:
        """What a resumed search must share with the run it continues (all but ``trials``)."""
        data = asdict(self)
        data.pop("trials")
        # searches made before these settings existed resume as before
        if data["max_cost_ratio"] is None:
            data.pop("max_cost_ratio")
        if data["alone"]:
            data.pop("alone")
        # the sampler picks the plans, so a resumed search keeps it; a search made before
        # --sampler used Optuna 5.0's TPESampler() (multivariate for one objective: tpe-joint)
        # for p80 and cost, NSGA-II for pareto, with 8 start-up trials, and has no key
        data.pop("sampler")
        legacy = "nsga2" if self.objective == "pareto" else "tpe-joint"
        if self.sampler_name != legacy:
            data["sampler"] = self.sampler_name
        if data["startup_trials"] == STARTUP_TRIALS or not self.sampler_name.startswith("tpe"):
            data.pop("startup_trials")
        if data["screen"] == "none":  # as every search before --screen
            data.pop("screen")
        return json.loads(json.dumps(data))
