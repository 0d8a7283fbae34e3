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
two crews that pay for themselves only together are met, then the sampler's
(``plan_study.make_sampler``: the joint TPE by default, NSGA-II for ``pareto``).

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

Its parts, each a module of ``training.search`` (issue 43: a module a reader holds at once):
``plan_space`` (the levers, the crew screen, a plan as changes), ``plan_config``
(``PlanConfig``), ``plan_floors`` (the floors played, kept in ``episodes.jsonl``),
``plan_scores`` (what a plan scores, the cost bound, the ranking), ``plan_study`` (Optuna's
study and sampler), ``plan_confirm`` (the held-out seeds, the plan chosen, each change alone)
and ``plan_outputs`` (the files). This module keeps the search itself (``search_plans``, in
named steps) and still offers, re-imported, the names the command and the docs give as
``training.search.plan_search.X`` (``__all__``).
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from cmdp_pymunk.cases.levers import Change, label_of, make_variant
from cmdp_pymunk.cases.load import CaseError
from cmdp_pymunk.cases.model import Case

from ..runs.backends import open_backend
from ..whatif import crew_counts
from .harness import progress_bar
from .plan_config import OBJECTIVES, SAMPLERS, SCREENS, PlanConfig
from .plan_confirm import Confirmation, confirm_plans, levers_rows
from .plan_floors import Floors, plan_job
from .plan_outputs import trial_rows, write_outputs
from .plan_scores import cost_bound, feasible, objective_values, scores
from .plan_space import BASE_LABEL, Lever, _changes_of, crew_screen, plan_changes, search_space
from .plan_study import _study

__all__ = [
    "PlanResult", "search_plans",
    # re-exported: ``cmdp-plan`` and docs/levers.md name them ``training.search.plan_search.X``
    "OBJECTIVES", "PlanConfig", "SAMPLERS", "SCREENS", "crew_screen", "search_space",
    "trial_rows", "write_outputs",
]


@dataclass
class PlanResult:
    """What ``search_plans`` found (``summary.json`` holds all of it)."""

    summary: dict
    chosen: object  # the chosen plan: a ``levers.Variant``, or the case as written (a Case)
    files: list[Path] = field(default_factory=list)


@dataclass
class SearchRun:
    """What the steps of one search share: the case, its settings and levers, the study, the
    floors played (``Floors``) and the progress bar whose total they keep true, and the plans
    made so far by label (``variant_of``: each plan's case is made once)."""

    case: Case
    config: PlanConfig
    space: list[Lever]
    study: object
    floors: Floors
    bar: object
    variants: dict[str, object] = field(default_factory=dict)

    @property
    def n_search(self) -> int:
        return len(self.config.search_seeds)

    @property
    def n_confirm(self) -> int:
        return len(self.config.confirm_seeds)

    def variant_of(self, changes: tuple[Change, ...]):
        """A plan's label and case, made once (``CaseError`` for a plan the case's checks
        refuse)."""
        label = label_of(changes)
        if label not in self.variants:
            self.variants[label] = make_variant(self.case, changes).case if changes else self.case
        return label, self.variants[label]

    def bound_of(self, rows: list[dict], rung: int) -> dict:
        """A plan's rows at a rung against the cost bound, paired with the case on the same
        ``rung`` search seeds (``cost_bound``)."""
        return cost_bound(rows, self.floors.of("event", BASE_LABEL,
                                               self.config.search_seeds[:rung]),
                          self.config.max_cost_ratio)


def search_plans(case: Case, config: PlanConfig, out: Path, calibration, case_path=None,
                 workers: int | None = 1, ray: str | None = None, resume: bool = False,
                 progress: bool = True, log=print) -> PlanResult:
    """The plan search of the module doc, into ``out``; ValueError naming the fix for bad
    settings or a run folder that does not fit ``resume``. ``calibration``: the event floor's
    (the base case's, ``eventfloor.calibration_for``)."""
    space, study = _open_search(case, config, out, resume)
    floors = {"event": ("event", calibration), "pymunk": ("pymunk", None)}
    n_search = len(config.search_seeds)
    n_confirm = len(config.confirm_seeds)
    # the true total: every trial's search seeds (a pruned plan's unplayed ones are taken off
    # when it is pruned), the case's as the cost bound's reference, then the confirmed plans,
    # the case and each change alone
    total = (config.trials * n_search + (config.confirm + 1) * n_confirm
             + len(space) * n_confirm + (n_search if config.constrained else 0))
    start = time.perf_counter()
    done_before = _counted(study)
    bar = progress_bar(total, 0, "floor", "cmdp-plan", progress)
    bar.total = total - done_before * n_search  # trials of a resumed run are not counted again
    with bar, open_backend(plan_job, None, workers, ray) as pool:
        run = SearchRun(case, config, space, study, Floors(out, pool, bar, floors, config), bar)
        if config.constrained:  # the bound's reference on every rung: the case on every seed
            run.floors.play("event", [(BASE_LABEL, case, s) for s in config.search_seeds])
        while _counted(study) < config.trials:
            _play_rungs(run, _ask_batch(run))
            bar.refresh()
        search_s = time.perf_counter() - start
        confirmation = confirm_plans(run)
        table_label, lever_rows = levers_rows(run, confirmation)
    wall = time.perf_counter() - start
    return _result(run, confirmation, table_label, lever_rows, case_path, calibration,
                   search_s, wall)


def _open_search(case: Case, config: PlanConfig, out: Path, resume: bool):
    """The levers and the study of a search into ``out`` (``ValueError`` naming every bad
    setting first); a new study is queued the case as written, then the crew screen."""
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
    if not study.trials:
        study.enqueue_trial({lv.key: lv.base for lv in space})  # the case as written first
        for values in screen:  # then the screen (crew_screen: pairs a sampler would miss)
            study.enqueue_trial(values, user_attrs={"screen": True})
    return space, study


def _counted(study) -> int:
    """The trials spent of the budget: told complete or pruned, or refused by the case."""
    from optuna.trial import TrialState

    return sum(1 for t in study.get_trials(deepcopy=False)
               if t.state in (TrialState.COMPLETE, TrialState.PRUNED)
               or t.user_attrs.get("invalid"))


def _ask_batch(run: SearchRun) -> list[tuple]:
    """The next ``batch`` trials asked of the study, each (trial, plan label, plan case); a
    plan the case's checks refuse is told failed at once and plays no floor."""
    from optuna.trial import TrialState

    config, study = run.config, run.study
    batch = []
    for _ in range(min(config.batch, config.trials - _counted(study))):
        trial = study.ask()
        values = {lv.key: lv.suggest(trial) for lv in run.space}
        changes = plan_changes(run.space, values)
        try:
            label, plan = run.variant_of(changes)
        except CaseError as err:  # a plan the case's checks refuse: not a floor
            trial.set_user_attr("invalid", str(err))
            trial.set_user_attr("plan", label_of(changes))
            study.tell(trial, state=TrialState.FAIL)
            run.bar.total -= run.n_search
            continue
        trial.set_user_attr("plan", label)
        batch.append((trial, label, plan))
    return batch


def _play_rungs(run: SearchRun, batch: list[tuple]) -> None:
    """A batch's plans up the pruner's rungs: each rung's new search seeds played for the plans
    still in, then each plan reported, pruned or told (``_plays_on``)."""
    config = run.config
    played = 0
    for rung in config.rungs():
        seeds = config.search_seeds[played:rung]
        run.floors.play("event", [(label, plan, s) for _, label, plan in batch for s in seeds])
        survivors = []
        for trial, label, plan in batch:
            if _plays_on(run, trial, label, rung):
                survivors.append((trial, label, plan))
        batch = survivors
        played = rung


def _plays_on(run: SearchRun, trial, label: str, rung: int) -> bool:
    """Whether a plan plays on to the next rung, after its scores on the rung's search seeds
    (``rung`` of them): failed if a floor did not finish, pruned by the pruner or as clearly
    over the cost bound, told complete at the last rung (module doc)."""
    from optuna.trial import TrialState

    config, study, bar, n_search = run.config, run.study, run.bar, run.n_search
    rows = run.floors.of("event", label, config.search_seeds[:rung])
    s = scores(rows)
    values = objective_values(config.objective, s)
    if values is None:
        trial.set_user_attr("unfinished", True)
        study.tell(trial, state=TrialState.FAIL)
        bar.total -= n_search - rung
        return False
    bound = run.bound_of(rows, rung) if config.constrained else None
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
            return False
    else:
        trial.set_user_attr("scores", s)
        if bound is not None:
            trial.set_constraint("cost", bound["cost_violation"])
        study.tell(trial, values)
        return False
    return True


def _tried(config: PlanConfig, trials: list, complete: list) -> dict:
    """summary.json's ``tried``: the trials by how they ended (and by the cost bound)."""
    from optuna.trial import TrialState

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
    return tried


def _result(run: SearchRun, c: Confirmation, table_label: str, lever_rows: list[dict],
            case_path, calibration, search_s: float, wall: float) -> PlanResult:
    """The search's result: the chosen plan and ``summary.json``'s contents (``c``: the
    confirmation, ``confirm_plans``)."""
    case, config, study = run.case, run.config, run.study
    tried = _tried(config, c.trials, c.complete)
    chosen_changes = _changes_of(case, c.chosen_label)
    chosen = make_variant(case, chosen_changes, "plan") if chosen_changes else case
    points = [{"plan": t.user_attrs["plan"], **t.user_attrs["scores"],
               "front": t.user_attrs["plan"] in c.front, "feasible": feasible(t)}
              for t in c.complete]
    summary = {
        "case": case.case.name, "case_file": str(case_path) if case_path else "built-in",
        "objective": config.objective, "settings": json.loads(json.dumps(asdict(config))),
        "max_cost_ratio": config.max_cost_ratio,
        "levers": [{**asdict(lv), "key": lv.key} for lv in run.space],
        "tried": tried,
        "search": {"floor": "event", "calibration": getattr(calibration, "fitted_on", "")
                   or "uncalibrated",
                   "calibration_fingerprint": getattr(calibration, "fingerprint", None),
                   "seeds": list(config.search_seeds), "rungs": config.rungs(),
                   "sampler": type(study.sampler).__name__,
                   "sampler_option": config.sampler_name, "screen": config.screen,
                   "pruner": type(study.pruner).__name__, "base": c.base_search,
                   "floors_played_now": run.floors.played, "wall_s": round(search_s, 1)},
        "confirmation": {"floor": config.confirm_fidelity, "seeds": list(config.confirm_seeds),
                         "base": c.base_held,
                         "plans": [{"plan": p, "search": c.best_by_plan[p],
                                    "held_out": c.held[p]} for p in c.confirmed]},
        "chosen": {"plan": c.chosen_label, "changes": [ch.label for ch in chosen_changes],
                   "crews": crew_counts(chosen if isinstance(chosen, Case) else chosen.case),
                   "held_out": c.held.get(c.chosen_label, c.base_held),
                   "note": "" if c.chosen_label != BASE_LABEL else
                   ("no confirmed plan beat the case as written on the held-out seeds"
                    + (" within the cost bound" if config.constrained else ""))},
        "levers_table": {"plan": table_label, "rows": lever_rows},
        "points": points, "wall_s": round(wall, 1),
    }
    return PlanResult(summary, chosen, [])
