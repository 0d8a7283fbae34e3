"""A plan search over a case's levers (issue 42 item 5; docs/levers.md, "A plan search").

The levers (``cmdp_pymunk.cases.levers``: crew counts, reorder points, crane lift batches,
storage spots, regions and capacities) span the search space (``search_space``): the case's
``[levers]`` bounds, or without them every crew type from one fewer to one more crew and every
stored material's reorder point from 0 to half its storage's capacity. A *plan* is one value
per lever: the case with those changes (``make_variant``), validated like any case.

Optuna searches it on the event floor (each plan on the base case's calibration, as
``cmdp-evaluate --variant`` runs it; ``benchmarks/validate_variants.py`` measures how well that
holds) for

- ``p80``: the lowest P80 makespan (the joint TPE; its seeds spent by Optuna's
  ``SuccessiveHalvingPruner``: every plan plays the first ``min_seeds`` search seeds, half of
  them go on to twice as many, and so on up to all of them, so close plans get the seeds);
- ``cost``: the lowest mean cost (``cmdp_pymunk.cost``; the same pruner);
- ``pareto``: the front of P80 makespan and mean cost (NSGA-II; Optuna's pruners do not
  serve studies of two objectives, so every plan plays every search seed).

``max_cost_ratio`` (``--max-cost-ratio``) bounds ``p80`` and ``pareto`` by cost: a plan is
feasible when its mean cost is at most that many times the case's on the same search seeds
(1.0: no dearer than the case). A search on time alone adds crews (issue 42), so the bound is
what makes "faster at no more cost" a question the search answers. It is Optuna's own
constraint handling, not a penalty on the objective: each trial's ``cost_ratio - bound`` is
set with ``Trial.set_constraint`` (Optuna 5.0's replacement of the samplers'
``constraints_func``, which 5.0 deprecates; TPE and NSGA-II read the same trial constraints),
TPE models infeasible trials apart from the feasible ones, NSGA-II ranks by constrained
domination, and ``best_trial``/``best_trials`` keep feasible trials only. The
``SuccessiveHalvingPruner`` knows no constraint (it ranks a rung's values alone, and a fast
but dear plan would push the feasible ones out of a rung), so only plans within the bound on
the rung's seeds (paired mean) compete in it: a plan clearly dearer (its paired cost
difference's 95 % interval lies above the bound) is pruned as infeasible before the pruner
sees it, and one over the bound on the mean but not clearly plays on to the next rung without
competing (seeds go where a plan is close to the bound as well as where plans are close to
each other). At the last rung the bound is read on the mean. The case as written plays every
search seed first, the reference of every rung.

Which plans: the case as written first, then the crew screen (``crew_screen``: each crew
type one fewer and one more, every two types one more each; ``--screen none`` skips it), so
two crews that pay for themselves only together are met, then the sampler's (``make_sampler``:
the joint TPE by default, NSGA-II for ``pareto``).

Common random numbers: every plan plays the same search seeds in the same order, and a task
meets the same pace in every plan (streams keyed by seed and task), so plans are compared on
the same futures. The case as written is the first trial. Trials are asked in batches of
``batch`` (``study.ask``) whose floors run on the backend together, so a search does not
depend on the number of workers; Optuna's samplers are seeded, so the same settings give the
same search.

Then the best ``confirm`` plans and the case as written play the held-out confirmation seeds
(disjoint from the search seeds) on the pymunk floor, with paired intervals against the case;
the chosen plan is the confirmed plan best on those seeds by the objective (for ``pareto``:
the lowest sum of P80 and cost each over the case's), or the case itself when none beats it.
What each of its changes is worth alone and all together is measured on the same seeds and
floor (``levers.md``/``levers.csv``).

The run folder: ``plan.journal`` (Optuna's journal storage, an append-only file: ``resume``
continues the study; its RDB storage on SQLite spent 10 s importing SQLAlchemy and creating
tables before a tiny search's first floor here),
``episodes.jsonl`` (every floor played, by floor, plan and seed: a resumed run plays none
twice), ``plan.toml`` (the chosen plan as a case file), ``plans/`` (each confirmed plan),
``media/pareto.png``, ``levers.md``, ``levers.csv``, ``trials.csv`` and ``summary.json``.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections import OrderedDict
from dataclasses import asdict, dataclass, field
from pathlib import Path

from cmdp_pymunk.cases.levers import Change, label_of, make_variant, variant_toml
from cmdp_pymunk.cases.load import CaseError
from cmdp_pymunk.cases.model import Case
from cmdp_pymunk.events import write_atomic

from ..runs.backends import open_backend
from ..runs.paired import mean_ci, paired, percentile
from ..runs.runner import EpisodeRunner
from ..whatif import crew_counts, played_row
from .harness import progress_bar

OBJECTIVES = ("p80", "cost", "pareto")
# the samplers a search may pick plans with (``--sampler``; ``make_sampler``)
SAMPLERS = ("tpe-joint", "tpe-independent", "nsga2", "random")
STARTUP_TRIALS = 8  # TPE's random start-up trials before it models the plans (the default)
SCREENS = ("crew-pairs", "none")  # the plans tried first, after the case (``--screen``)
STEPS = 4  # a continuous lever is searched on STEPS + 1 values between its bounds
STALL_S = 3600.0
BASE_LABEL = "as the case"


# -- the search space ----------------------------------------------------------------------

@dataclass(frozen=True)
class Lever:
    """One searched lever: the change's ``kind``, ``name`` and ``field`` (as
    ``cmdp_pymunk.cases.levers.Change``), its values from ``low`` to ``high`` (whole numbers
    for crew counts and storage spots, else every ``step``), and its value in the case as
    written (``base``; a storage spot's base is -1: where the case puts it)."""

    kind: str
    name: str
    field: str
    low: float
    high: float
    step: float
    base: float

    @property
    def key(self) -> str:
        """``crews.RC``, ``rebars.reorder_at``, ``ST-rebars.spot``: Optuna's parameter name."""
        return f"crews.{self.name}" if self.kind == "crews" else f"{self.name}.{self.field}"

    @property
    def whole(self) -> bool:
        return self.kind == "crews" or self.field == "spot"

    def suggest(self, trial) -> float:
        if self.whole:
            return float(trial.suggest_int(self.key, int(self.low), int(self.high)))
        return round(trial.suggest_float(self.key, self.low, self.high, step=self.step), 9)

    def change(self, value: float) -> Change | None:
        """The change that sets this lever to ``value``; None for the case's own value."""
        if math.isclose(value, self.base, abs_tol=1e-9):
            return None
        if self.kind == "crews":
            return Change("crews", self.name, "count", "=", float(int(value)))
        return Change(self.kind, self.name, self.field, "=", float(value))


def _grid(low: float, high: float) -> tuple[float, float, float]:
    step = (high - low) / STEPS
    return low, high, step


def search_space(case: Case) -> list[Lever]:
    """The levers a plan may move (module doc): the case's ``[levers]`` with their bounds
    (crew counts ``min``..``max``, a storage's ``spots`` by index, -1 the case's own, its
    ``region`` and every bounded number on ``STEPS + 1`` values), or without ``[levers]``
    every crew type at one fewer (at least 1) to one more crew and every stored material's
    reorder point from 0 to half the lowest capacity of its storages. Levers that cannot move
    (equal bounds) are left out."""
    counts = {t: sum(c.type == t for c in case.crews) for t in case.crew_types}
    out: list[Lever] = []
    levers = case.levers
    if levers is None:
        for t, n in counts.items():
            if n:
                out.append(Lever("crews", t, "count", max(1, n - 1), n + 1, 1, n))
        for m, material in case.materials.items():
            caps = [s.capacity for s in case.storages if s.material == m]
            if caps:
                out.append(Lever("materials", m, "reorder_at", *_grid(0.0, min(caps) / 2),
                                 material.reorder_at))
        return [lv for lv in out if lv.high > lv.low]
    for t, lever in levers.crews.items():
        out.append(Lever("crews", t, "count", lever.min, lever.max, 1, counts.get(t, 0)))
    for m, lever in levers.materials.items():
        for f in ("reorder_at", "crane_lift_quantity"):
            bounds = getattr(lever, f)
            if bounds is not None:
                out.append(Lever("materials", m, f, *_grid(*bounds),
                                 getattr(case.materials[m], f)))
    storages = {s.id: s for s in case.storages}
    for sid, lever in levers.storages.items():
        s = storages[sid]
        if lever.spots:
            out.append(Lever("storages", sid, "spot", -1, len(lever.spots) - 1, 1, -1))
        elif lever.region is not None:
            x0, y0, x1, y1 = lever.region
            out.append(Lever("storages", sid, "x_m", *_grid(x0, x1), s.x_m))
            out.append(Lever("storages", sid, "y_m", *_grid(y0, y1), s.y_m))
        if lever.capacity is not None:
            out.append(Lever("storages", sid, "capacity", *_grid(*lever.capacity), s.capacity))
    return [lv for lv in out if lv.high > lv.low]


def crew_screen(space: list[Lever]) -> list[dict[str, float]]:
    """The plans a ``crew-pairs`` screen tries first, after the case as written (each a value
    per lever key; every other lever as the case): each crew type one fewer and one more
    crew, then every two crew types one more each, within the levers' bounds.

    Why pairs: a crew is paid by the hour, so one more crew pays for itself only if the floor
    gets faster by more than the crew's share of the hourly cost. On the built-in floor one
    more RC crew alone (0.94 x) or FC crew alone (0.97 x) is dearer than the case, and one of
    each is 0.80 x and cheaper (the binding type moves as crews change; docs/levers.md). A
    cost bound makes both single changes infeasible, so a sampler learns to keep away from
    more crews and never tries the pair: it must be met before a model can keep it. With k
    crew types the screen is at most 2k + k(k-1)/2 plans (17 for the built-in floor's 5)."""
    crews = [lv for lv in space if lv.kind == "crews"]
    base = {lv.key: lv.base for lv in space}
    plans = [base | {lv.key: v} for lv in crews for v in (lv.base - 1, lv.base + 1)
             if lv.low <= v <= lv.high]
    plans += [base | {a.key: a.base + 1, b.key: b.base + 1}
              for i, a in enumerate(crews) for b in crews[i + 1:]
              if a.base + 1 <= a.high and b.base + 1 <= b.high]
    return plans


def plan_changes(space: list[Lever], values: dict[str, float]) -> tuple[Change, ...]:
    """The changes of a plan (its value per lever key), in the space's order; a storage spot of
    -1 (the case's own place) is no change."""
    out = []
    for lever in space:
        value = values[lever.key]
        if lever.field == "spot" and value < 0:
            continue
        change = lever.change(value)
        if change is not None:
            out.append(change)
    return tuple(out)


# -- the settings ----------------------------------------------------------------------------

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


# -- playing floors --------------------------------------------------------------------------

_RUNNERS: OrderedDict[str, EpisodeRunner] = OrderedDict()
_KEEP = 16  # runners kept per worker process (a plan's engine is made again after that)


def plan_job(_runner, key: str, case_data: dict, runner_args: tuple, evaluator: str,
             seed: int) -> dict:
    """One floor of one plan on one seed (``training.whatif.played_row``: the makespan and
    what it cost), in a worker that keeps the runners of its last ``_KEEP`` plans."""
    runner = _RUNNERS.pop(key, None)
    if runner is None:
        from cmdp_pymunk.cases.load import case_from_dict

        runner = EpisodeRunner(case_from_dict(case_data, key), *runner_args)
    _RUNNERS[key] = runner
    while len(_RUNNERS) > _KEEP:
        _RUNNERS.popitem(last=False)
    row = played_row(runner, evaluator, "scripted", seed)
    return {k: row[k] for k in ("makespan_s", "finished", "crane_lifts", "cost",
                                "cost_crew_rates_x2", "stall_reason")}


class Floors:
    """Every floor played, kept by (floor, plan, seed) in ``episodes.jsonl`` (a line each, as
    it comes: a resumed run reads them back and plays none twice), and ``play`` for the ones
    not yet played, on the backend."""

    def __init__(self, out: Path, pool, bar, floors: dict[str, tuple], config: PlanConfig):
        self.path = out / "episodes.jsonl"
        self.pool, self.bar, self.floors, self.config = pool, bar, floors, config
        self.rows: dict[tuple[str, str, int], dict] = {}
        if self.path.is_file():
            for line in self.path.read_text(encoding="utf-8").splitlines():
                try:
                    r = json.loads(line)
                except json.JSONDecodeError:  # a line cut by a crash: played again
                    continue
                self.rows[(r["floor"], r["plan"], r["seed"])] = r
        self.played = 0

    def play(self, fidelity: str, wanted: list[tuple[str, Case, int]]) -> None:
        """Play the (plan label, case, seed) floors of ``wanted`` not yet kept."""
        todo, seen = [], set()
        for label, case, seed in wanted:
            if (label, seed) not in seen and (fidelity, label, seed) not in self.rows:
                todo.append((label, case, seed))
            seen.add((label, seed))
        counted = len(wanted) - len(todo)  # already kept: counted on the bar at once
        if counted:
            self.bar.update(counted)
        if not todo:
            return
        dumps: dict[str, tuple[str, dict]] = {}
        jobs = []
        for label, case, seed in todo:
            if label not in dumps:
                data = case.model_dump(mode="json")
                # a worker keeps runners by this key: the case's digest beside the plan's label,
                # so two searches in one process (of two cases) never share a runner
                digest = hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()
                dumps[label] = (f"{fidelity}:{label}:{digest[:16]}", data)
            jobs.append((*dumps[label],
                         (self.config.stall_s, None, False, None, *self.floors[fidelity]),
                         self.config.evaluator, seed))
        with self.path.open("a", encoding="utf-8") as log:
            for i, row in self.pool.as_completed(jobs):
                label, _, seed = todo[i]
                r = {"floor": fidelity, "plan": label, "seed": seed, **row}
                self.rows[(fidelity, label, seed)] = r
                log.write(json.dumps(r) + "\n")
                log.flush()
                self.bar.update(1)
                self.played += 1

    def of(self, fidelity: str, label: str, seeds) -> list[dict]:
        return [self.rows[(fidelity, label, s)] for s in seeds
                if (fidelity, label, s) in self.rows]


# -- what a plan scores ----------------------------------------------------------------------

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


# -- the search ------------------------------------------------------------------------------

@dataclass
class PlanResult:
    """What ``search_plans`` found (``summary.json`` holds all of it)."""

    summary: dict
    chosen: object  # the chosen plan: a ``levers.Variant``, or the case as written (a Case)
    files: list[Path] = field(default_factory=list)


STUDY_FILE = "plan.journal"


def study_storage(out: Path):
    """The study's storage in the run folder: Optuna's journal file (``STUDY_FILE``)."""
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    return JournalStorage(JournalFileBackend(str(out / STUDY_FILE)))


def _study(out: Path, config: PlanConfig, resume: bool, screened: int = 0):
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    db = out / STUDY_FILE
    if db.exists() and not resume:
        raise ValueError(f"{out} already holds a plan search ({db.name}); fix: add --resume "
                         "to continue it, or give another --out")
    if resume and not db.exists():
        raise ValueError(f"--resume: {out} holds no plan search ({db.name}); fix: start one "
                         "without --resume")
    sampler = make_sampler(config, screened)
    if config.objective == "pareto":
        pruner, directions = optuna.pruners.NopPruner(), ["minimize", "minimize"]
    else:
        pruner = optuna.pruners.SuccessiveHalvingPruner(
            min_resource=config.min_seeds, reduction_factor=config.reduction_factor)
        directions = ["minimize"]
    study = optuna.create_study(storage=study_storage(out), study_name="plan",
                                directions=directions, sampler=sampler, pruner=pruner,
                                load_if_exists=True)
    kept = study.user_attrs.get("config")
    if kept is None:
        study.set_user_attr("config", config.fingerprint())
    elif kept != config.fingerprint():
        now = config.fingerprint()
        changed = sorted(k for k in kept.keys() | now.keys() if kept.get(k) != now.get(k))
        raise ValueError(f"--resume: {out} was searched with other settings ({', '.join(changed)}"
                         "); fix: resume with the same settings (only --trials may grow), or "
                         "start a new search in another --out")
    return study


def make_sampler(config: PlanConfig, screened: int = 0):
    """The Optuna sampler of ``config.sampler_name``, seeded with ``config.seed``:
    ``tpe-joint`` is ``TPESampler(multivariate=True, group=True)``, one Parzen estimator over
    every lever at once, so a plan good because two levers moved together (one more crew of
    each of two types) is sampled again as a pair. It is what Optuna 5.0's ``TPESampler()``
    does for one objective (``multivariate=None`` means True there), so every search before
    ``--sampler`` was already joint; ``group`` changes nothing while every plan sets every
    lever, and says so for ``pareto``, where ``multivariate`` would default to False.
    ``tpe-independent``: ``multivariate=False``, one estimator per lever. Both start with
    ``config.startup_trials`` random plans and read the trials' constraints. ``nsga2``:
    NSGA-II (constrained domination), a population of
    ``max(4, batch)``; ``random``: Optuna's RandomSampler, the baseline a model must beat.
    ``screened``: the screen's plans, tried before TPE's random start-up trials (so TPE still
    explores ``startup_trials`` random plans before it models them)."""
    import warnings

    import optuna

    name = config.sampler_name
    if name == "nsga2":
        return optuna.samplers.NSGAIISampler(seed=config.seed,
                                             population_size=max(4, config.batch))
    if name == "random":
        return optuna.samplers.RandomSampler(seed=config.seed)
    if name == "tpe-independent":
        return optuna.samplers.TPESampler(seed=config.seed, multivariate=False,
                                          n_startup_trials=config.startup_trials + screened)
    with warnings.catch_warnings():
        # group is experimental in Optuna 5.0 (ExperimentalWarning); every plan sets every
        # lever, so the group is the whole space and the option only states that intent
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        return optuna.samplers.TPESampler(seed=config.seed, multivariate=True, group=True,
                                          n_startup_trials=config.startup_trials + screened)


def search_plans(case: Case, config: PlanConfig, out: Path, calibration, case_path=None,
                 workers: int | None = 1, ray: str | None = None, resume: bool = False,
                 progress: bool = True, log=print) -> PlanResult:
    """The plan search of the module doc, into ``out``; ValueError naming the fix for bad
    settings or a run folder that does not fit ``resume``. ``calibration``: the event floor's
    (the base case's, ``eventfloor.calibration_for``)."""
    from optuna.trial import TrialState

    problems = config.problems()
    space = search_space(case)
    if not space:
        problems.append("the case has no lever that can move; fix: give bounds in [levers] "
                        "(docs/levers.md)")
    if problems:
        raise ValueError("; ".join(problems))
    out.mkdir(parents=True, exist_ok=True)
    screen = crew_screen(space) if config.screen == "crew-pairs" else []
    screen = screen[:max(0, config.trials - 1)]  # within the budget: the case is the first
    study = _study(out, config, resume, len(screen))
    for t in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
        study.tell(t.number, state=TrialState.FAIL)  # stopped with its run: asked again
    floors = {"event": ("event", calibration), "pymunk": ("pymunk", None)}

    def counted() -> int:
        return sum(1 for t in study.get_trials(deepcopy=False)
                   if t.state in (TrialState.COMPLETE, TrialState.PRUNED)
                   or t.user_attrs.get("invalid"))

    if not study.trials:
        study.enqueue_trial({lv.key: lv.base for lv in space})  # the case as written first
        for values in screen:  # then the screen (crew_screen: pairs a sampler would miss)
            study.enqueue_trial(values, user_attrs={"screen": True})
    n_search = len(config.search_seeds)
    n_confirm = len(config.confirm_seeds)
    # the true total: every trial's search seeds (a pruned plan's unplayed ones are taken off
    # when it is pruned), the case's as the cost bound's reference, then the confirmed plans,
    # the case and each change alone
    total = (config.trials * n_search + (config.confirm + 1) * n_confirm
             + len(space) * n_confirm + (n_search if config.constrained else 0))
    start = time.perf_counter()
    done_before = counted()
    bar = progress_bar(total, 0, "floor", "cmdp-plan", progress)
    bar.total = total - done_before * n_search  # trials of a resumed run are not counted again
    with bar, open_backend(plan_job, None, workers, ray) as pool:
        floors_ = Floors(out, pool, bar, floors, config)
        variants: dict[str, object] = {}

        def variant_of(changes: tuple[Change, ...]):
            label = label_of(changes)
            if label not in variants:
                variants[label] = make_variant(case, changes).case if changes else case
            return label, variants[label]

        if config.constrained:  # the bound's reference on every rung: the case on every seed
            floors_.play("event", [(BASE_LABEL, case, s) for s in config.search_seeds])

        def bound_of(rows: list[dict], rung: int) -> dict:
            return cost_bound(rows, floors_.of("event", BASE_LABEL, config.search_seeds[:rung]),
                              config.max_cost_ratio)

        while counted() < config.trials:
            batch = []
            for _ in range(min(config.batch, config.trials - counted())):
                trial = study.ask()
                values = {lv.key: lv.suggest(trial) for lv in space}
                changes = plan_changes(space, values)
                try:
                    label, plan = variant_of(changes)
                except CaseError as err:  # a plan the case's checks refuse: not a floor
                    trial.set_user_attr("invalid", str(err))
                    trial.set_user_attr("plan", label_of(changes))
                    study.tell(trial, state=TrialState.FAIL)
                    bar.total -= n_search
                    continue
                trial.set_user_attr("plan", label)
                batch.append((trial, label, plan))
            played = 0
            for rung in config.rungs():
                seeds = config.search_seeds[played:rung]
                floors_.play("event", [(label, plan, s) for _, label, plan in batch
                                       for s in seeds])
                survivors = []
                for trial, label, plan in batch:
                    rows = floors_.of("event", label, config.search_seeds[:rung])
                    s = scores(rows)
                    values = objective_values(config.objective, s)
                    if values is None:
                        trial.set_user_attr("unfinished", True)
                        study.tell(trial, state=TrialState.FAIL)
                        bar.total -= n_search - rung
                        continue
                    bound = bound_of(rows, rung) if config.constrained else None
                    if bound is not None:
                        s = {**s, "cost_ratio": bound["cost_ratio"],
                             "cost_violation": bound["cost_violation"]}
                    if rung < n_search:
                        trial.report(values[0], rung)
                        # the pruner ranks a rung's values alone, so only plans within the
                        # bound at this rung compete in it (a fast, dear plan would push the
                        # feasible ones out); one clearly over is pruned as infeasible, one
                        # over on the mean but not clearly plays on: seeds go where a plan is
                        # close to the bound too
                        over = bound is not None and bound["clearly_over"]
                        compete = bound is None or bound["cost_violation"] <= 0
                        if over or (compete and trial.should_prune()):
                            trial.set_user_attr("scores", s)
                            if over:
                                trial.set_user_attr("over_cost_at", rung)
                            if bound is not None:
                                trial.set_constraint("cost", bound["cost_violation"])
                            study.tell(trial, state=TrialState.PRUNED)
                            bar.total -= n_search - rung
                            continue
                    else:
                        trial.set_user_attr("scores", s)
                        if bound is not None:
                            trial.set_constraint("cost", bound["cost_violation"])
                        study.tell(trial, values)
                        continue
                    survivors.append((trial, label, plan))
                batch = survivors
                played = rung
            bar.refresh()
        search_s = time.perf_counter() - start

        # -- confirmation on held-out seeds ----------------------------------------------
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
        wanted = [(p, variant_of(_changes_of(case, p))[1], s)
                  for p in [BASE_LABEL, *confirmed] for s in config.confirm_seeds]
        bar.total -= (config.confirm - len(confirmed)) * n_confirm
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

        # -- what each change is worth alone and together -----------------------------------
        table_label = chosen_label if chosen_label != BASE_LABEL else \
            (confirmed[0] if confirmed else BASE_LABEL)
        changes = _changes_of(case, table_label)
        alone = [(c.label, (c,)) for c in changes] if len(changes) > 1 and config.alone \
            else []
        bar.total -= (len(space) - len(alone)) * n_confirm
        floors_.play(cf, [(label_of(ch), variant_of(ch)[1], s) for _, ch in alone
                          for s in config.confirm_seeds])
        lever_rows = [{"lever": "as the case", **_against(base_rows, base_rows)}]
        for name, ch in alone:
            lever_rows.append({"lever": name, **_against(
                floors_.of(cf, label_of(ch), config.confirm_seeds), base_rows)})
        if changes:
            lever_rows.append({"lever": "together: " + table_label, **_against(
                floors_.of(cf, table_label, config.confirm_seeds), base_rows)})
    wall = time.perf_counter() - start

    states = [t.state for t in trials]
    tried = {"trials": len([t for t in trials if t.state != TrialState.FAIL
                            or t.user_attrs.get("invalid") or t.user_attrs.get("unfinished")]),
             "complete": states.count(TrialState.COMPLETE),
             "pruned": states.count(TrialState.PRUNED),
             "refused": sum(1 for t in trials if t.user_attrs.get("invalid")),
             "unfinished": sum(1 for t in trials if t.user_attrs.get("unfinished")),
             "distinct_plans": len({t.user_attrs.get("plan") for t in trials
                                    if t.user_attrs.get("plan")}),
             "screened": sum(1 for t in trials if t.user_attrs.get("screen"))}
    if config.constrained:
        told = [t for t in trials if t.constraints]
        tried |= {"feasible": sum(1 for t in told if feasible(t)),
                  "infeasible": sum(1 for t in told if not feasible(t)),
                  "over_cost_early": sum(1 for t in trials if t.user_attrs.get("over_cost_at")),
                  "feasible_complete": sum(1 for t in complete if feasible(t))}
    chosen_changes = _changes_of(case, chosen_label)
    chosen = make_variant(case, chosen_changes, "plan") if chosen_changes else case
    points = [{"plan": t.user_attrs["plan"], **t.user_attrs["scores"],
               "front": t.user_attrs["plan"] in front, "feasible": feasible(t)}
              for t in complete]
    summary = {
        "case": case.case.name, "case_file": str(case_path) if case_path else "built-in",
        "objective": config.objective, "settings": json.loads(json.dumps(asdict(config))),
        "max_cost_ratio": config.max_cost_ratio,
        "levers": [{**asdict(lv), "key": lv.key} for lv in space],
        "tried": tried,
        "search": {"floor": "event", "calibration": getattr(calibration, "fitted_on", "")
                   or "uncalibrated",
                   "calibration_fingerprint": getattr(calibration, "fingerprint", None),
                   "seeds": list(config.search_seeds), "rungs": config.rungs(),
                   "sampler": type(study.sampler).__name__,
                   "sampler_option": config.sampler_name, "screen": config.screen,
                   "pruner": type(study.pruner).__name__, "base": base_search,
                   "floors_played_now": floors_.played, "wall_s": round(search_s, 1)},
        "confirmation": {"floor": cf, "seeds": list(config.confirm_seeds),
                         "base": base_held,
                         "plans": [{"plan": p, "search": best_by_plan[p], "held_out": held[p]}
                                   for p in confirmed]},
        "chosen": {"plan": chosen_label, "changes": [c.label for c in chosen_changes],
                   "crews": crew_counts(chosen if isinstance(chosen, Case) else chosen.case),
                   "held_out": held.get(chosen_label, base_held),
                   "note": "" if chosen_label != BASE_LABEL else
                   ("no confirmed plan beat the case as written on the held-out seeds"
                    + (" within the cost bound" if config.constrained else ""))},
        "levers_table": {"plan": table_label, "rows": lever_rows},
        "points": points, "wall_s": round(wall, 1),
    }
    return PlanResult(summary, chosen, [])


def _changes_of(case: Case, label: str) -> tuple[Change, ...]:
    """The changes of a plan by its label (``levers.label_of``'s text reads back)."""
    if label == BASE_LABEL:
        return ()
    from cmdp_pymunk.cases.levers import parse_changes

    return parse_changes(case, label, "cmdp-plan")


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


# -- the outputs -----------------------------------------------------------------------------

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
