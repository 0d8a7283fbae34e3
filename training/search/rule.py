"""An extended Eq. 9 with searched weights (issue 17, item 7): CMA-ES under common random numbers.

The rule is ``agents.student.StudentEvaluator``: Eq. 9's V' plus ``w . phi`` over the crew's
``candidates`` best targets by Eq. 9, phi the candidate features of ``agents.features``. Here
one weight vector serves every crew type, and only the ``features`` named in the config are
searched (the others stay 0): by default Eq. 9's three terms (a change of its betas) plus the
critical-path tail (slack) and the work a target unlocks for the bottleneck crews. With every
weight 0 the rule is Eq. 9, which is where the search starts.

The search is CMA-ES (the ``cma`` package), minimizing the *paired* makespan difference to
Eq. 9: each generation draws ``seeds_per_generation`` seeds from the training pool (the same
seeds for every candidate of that generation, so candidates meet on common random numbers)
and a candidate's fitness is the mean over them of (its makespan - Eq. 9's makespan on the
same seed); Eq. 9's makespans are run once per seed and cached. An unfinished floor scores
``training.search.genetic.unfinished_makespan_s``.

After the last generation the distribution's means (CMA-ES's estimates of the optimum, less
noisy than the best sample of one generation) after every ``select_every``-th generation and
after the last meet Eq. 9 on ``select_seeds``, seeds the search never saw: each generation's
fitness comes from its own draw of seeds, so the log alone cannot say which mean is best. The
one with the lowest paired difference is kept; if none is below 0, the result is Eq. 9 itself
(every weight 0: a rule replaces the heuristic only where the selection seeds say it is
better). Its paired difference and 95 % interval go into the result file; picked among several
on the same seeds, it is optimistic, so a strategy comparison reports the rule on other seeds
again (``cmdp-evaluate --seeds 100-139``).

The generations may run on the event floor (``fidelity = "event"``, the case's calibration
beside it or ``calibration``): about 50 x cheaper, so hundreds of seeds a generation fit two
cores. The selection runs on ``select_fidelity``, the pymunk floor by default: the event floor
proposes, the paper's floor decides (each seed's Eq. 9 baseline on the floor its seed runs on).

With ``start`` (a student's JSON: ``distill fit``, a policy-iteration round, an earlier search)
the search starts there instead of at Eq. 9: the vector is an offset on the student's weights
(the same for every crew type, or with ``per_type`` one block per crew type the student has
weights for), the features not searched keep the student's weights, and generation 0 (the
student itself) is checked on the selection seeds beside the means, so the student is kept
unless a mean beats it there (``training/configs/rule_search_student.toml``).

A checkpoint after every generation holds the CMA-ES state (pickled whole, with its random
generator), so ``--resume`` continues exactly as the uninterrupted run.
"""

from __future__ import annotations

import pickle
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, Strict, field_validator, model_validator

from agents.features import ALL_FEATURES, FEATURE_NAMES
from agents.student import StudentEvaluator
from cmdp_pymunk.events import write_atomic

from ..runs.runner import EpisodeRunner
from . import harness as search
from .genetic import unfinished_makespan_s

Count = Annotated[int, Strict(), Field(gt=0)]
CountOrZero = Annotated[int, Strict(), Field(ge=0)]
Positive = Annotated[float, Strict(), Field(gt=0, allow_inf_nan=False)]
Seeds = Annotated[list[CountOrZero], Field(min_length=1)]

DEFAULT_FEATURES = ("successors", "nearness", "conflicts", "tail", "unlocks_bottleneck")


class RuleSearchConfig(BaseModel):
    """Every setting of a rule search (``training/configs/rule_search.toml``; ``--set``)."""

    model_config = ConfigDict(extra="forbid")

    case: str | None = None  # case file; None: the built-in case
    seed: CountOrZero = 0  # CMA-ES's own randomness and the draw of each generation's seeds
    features: Annotated[list[str], Field(min_length=1)] = list(DEFAULT_FEATURES)
    candidates: Count = 5  # how many of Eq. 9's best targets the rule may re-rank
    sigma0: Positive = 0.3  # CMA-ES's initial step size (features and V' are about [0, 1])
    popsize: Count | None = None  # None: CMA-ES's default, 4 + 3 ln(dimension)
    generations: CountOrZero = 12
    train_seeds: Seeds = list(range(30))  # the pool each generation draws from
    seeds_per_generation: Count = 10
    select_seeds: Seeds = list(range(40, 60))  # the final check against Eq. 9, never searched on
    select_every: Count = 1  # check the mean after every so many generations (and the last)
    navigator: str = "scripted"
    stall_s: Positive = 3600.0
    max_time_s: Positive | None = None  # None: the case's
    fidelity: Literal["pymunk", "event"] = "pymunk"  # the floor the generations run on
    select_fidelity: Literal["pymunk", "event"] = "pymunk"  # and the selection (module doc)
    calibration: str | None = None  # the event floor's file; None: the case's, beside it
    # Start from a student (a ``distill fit`` or earlier search's JSON) instead of Eq. 9: the
    # search vector is then an offset on its weights (``rule_weights``), one for every crew type
    # or, with ``per_type``, one block of ``features`` per crew type the student has weights for.
    start: str | None = None
    per_type: bool = False

    @field_validator("features")
    @classmethod
    def _known_features(cls, names: list[str]) -> list[str]:
        unknown = [n for n in names if n not in ALL_FEATURES]
        if unknown or len(set(names)) != len(names):
            raise ValueError(f"features {names}: each once, from {', '.join(ALL_FEATURES)}")
        return names

    @model_validator(mode="after")
    def _start_fits(self) -> RuleSearchConfig:
        if self.start is None:
            if self.per_type:
                raise ValueError("per_type = true searches offsets on a start student's "
                                 "per-type weights; fix: give start = \"PATH\" (a student "
                                 "JSON) or drop per_type")
            return self
        student = start_student(self.start)
        missing = [n for n in self.features if n not in student.features]
        if missing:
            raise ValueError(f"features {missing} are not the start student's "
                             f"({self.start}: {', '.join(student.features)}); fix: search "
                             "among its features")
        if student.candidates != self.candidates:
            raise ValueError(f"candidates = {self.candidates}, the start student "
                             f"({self.start}) re-ranks {student.candidates}; fix: candidates = "
                             f"{student.candidates}")
        return self

    @model_validator(mode="after")
    def _seeds_fit(self) -> RuleSearchConfig:
        if self.seeds_per_generation > len(set(self.train_seeds)):
            raise ValueError(f"seeds_per_generation = {self.seeds_per_generation} exceeds the "
                             f"{len(set(self.train_seeds))} train_seeds; fix: lower it or give "
                             "more train_seeds")
        shared = sorted(set(self.train_seeds) & set(self.select_seeds))
        if shared:
            raise ValueError(f"select_seeds {shared} are also train_seeds; fix: select on "
                             "seeds the search never sees")
        return self


def generation_seeds(config: RuleSearchConfig, generation: int) -> list[int]:
    """The seeds every candidate of ``generation`` is scored on: drawn without replacement
    from the pool, the same for a given (config seed, generation)."""
    pool = sorted(set(config.train_seeds))
    rng = np.random.default_rng([config.seed, 17, generation])
    return sorted(int(s) for s in rng.choice(pool, config.seeds_per_generation, replace=False))


@lru_cache(maxsize=8)
def start_student(path: str) -> StudentEvaluator:
    """A search's start student (``RuleSearchConfig.start``), read once."""
    return StudentEvaluator.load(path)


def student_features(config: RuleSearchConfig) -> tuple[str, ...]:
    """The student's features: the start student's; else ``FEATURE_NAMES`` when the search
    names only those (the files of the first searches), else ``ALL_FEATURES``."""
    if config.start is not None:
        return start_student(config.start).features
    return FEATURE_NAMES if set(config.features) <= set(FEATURE_NAMES) else ALL_FEATURES


def searched_types(config: RuleSearchConfig, crew_types) -> list[str]:
    """The crew types with a block of their own (``per_type``): the case's types the start
    student holds weights for (a type it has none for never re-ranks: a crane crew's), sorted;
    none without ``per_type``."""
    if not config.per_type:
        return []
    return sorted(set(crew_types) & set(start_student(config.start).weights))


def search_names(config: RuleSearchConfig, crew_types) -> list[str]:
    """The search vector's entries by name: the features, or TYPE.feature with ``per_type``."""
    if not config.per_type:
        return list(config.features)
    return [f"{t}.{n}" for t in searched_types(config, crew_types) for n in config.features]


def search_dimension(config: RuleSearchConfig, crew_types) -> int:
    """The length of the search vector: a weight per searched feature, per crew type with
    ``per_type`` (``searched_types``)."""
    return len(search_names(config, crew_types))


def rule_weights(config: RuleSearchConfig, x, crew_types) -> dict[str, list[float]]:
    """The search vector ``x`` as the student's weights over ``student_features``: without a
    start, the same vector for every crew type (zeros for the features not searched); with
    one, the start student's weights per crew type plus ``x`` on the searched features (with
    ``per_type``, crew type k's block of ``x`` for the k-th of ``searched_types``; the other
    types keep the start's weights)."""
    names = student_features(config)
    crew_types = sorted(crew_types)
    x = np.asarray(x, dtype=np.float64)
    if x.shape != (search_dimension(config, crew_types),):
        raise ValueError(f"search vector of {x.shape[0]} numbers, expected "
                         f"{search_dimension(config, crew_types)}")
    start = start_student(config.start).weights if config.start is not None else {}
    blocks = {t: x[k * len(config.features):(k + 1) * len(config.features)]
              for k, t in enumerate(searched_types(config, crew_types))}
    out = {}
    for crew_type in crew_types:
        full = np.array(start.get(crew_type, np.zeros(len(names))), dtype=np.float64)
        block = blocks.get(crew_type) if config.per_type else x
        if block is not None:
            for name, value in zip(config.features, block, strict=True):
                full[names.index(name)] += float(value)
        out[crew_type] = full.tolist()
    return out


def paired_fitness(makespans: list[float | None], baseline: list[float | None],
                   limit_s: float) -> float:
    """Mean over seeds of (candidate's makespan - Eq. 9's on the same seed), an unfinished
    floor (None) counting as ``unfinished_makespan_s(limit_s)`` on either side."""
    def score(m):
        return unfinished_makespan_s(limit_s) if m is None else m

    return float(np.mean([score(m) - score(b) for m, b in zip(makespans, baseline,
                                                                 strict=True)]))


def _rule_job(runner: EpisodeRunner, weights, candidates: int, seed: int, navigator: str,
              features: tuple[str, ...] = FEATURE_NAMES):
    evaluator = "priority" if weights is None else StudentEvaluator(weights, candidates,
                                                                    features)
    row = runner.run(evaluator, navigator, seed)
    return {"seed": seed, "makespan_s": row["makespan_s"] if row["finished"] else None,
            "finished": row["finished"]}


@dataclass
class SearchState:
    """A checkpoint: generations done, the CMA-ES object, the log, Eq. 9's makespan per seed,
    the selection result once done, the settings it was made with."""

    generation: int
    es: object
    log: list[dict] = field(default_factory=list)
    baseline: dict = field(default_factory=dict)
    selection: dict | None = None
    config: dict = field(default_factory=dict)
    evaluations: int = 0
    checked: dict = field(default_factory=dict)  # generation -> its mean on the select seeds


def generations_checked(config: RuleSearchConfig) -> list[int]:
    """The generations whose means meet Eq. 9 on the selection seeds; with a start student,
    generation 0 too (the start itself: the search keeps it unless a mean beats it)."""
    last = config.generations
    every = {g for g in range(1, last + 1) if g % config.select_every == 0}
    first = {0} if config.start is not None else set()
    return sorted(first | every | ({last} if last > 0 else set()))


def total_episodes(config: RuleSearchConfig, popsize: int) -> int:
    """Every episode a whole run plays: Eq. 9 once per seed, each generation's candidates,
    and the selection check."""
    return (len(set(config.train_seeds) | set(config.select_seeds))
            + config.generations * popsize * config.seeds_per_generation
            + len(generations_checked(config)) * len(config.select_seeds))


def new_strategy(config: RuleSearchConfig, dimension: int | None = None):
    import cma

    options = {"seed": config.seed + 1, "verbose": -9}  # cma reads seed 0 as "from the clock"
    if config.popsize is not None:
        options["popsize"] = config.popsize
    return cma.CMAEvolutionStrategy(np.zeros(dimension or len(config.features)), config.sigma0,
                                    options)


def search_rule(case, config: RuleSearchConfig, out: Path, workers: int | None = 1,
                resume: bool = False, progress: bool = True,
                ray: str | None = None) -> SearchState:
    """Run (or resume) the search; writes ``out/checkpoint.pkl`` and ``out/history.csv``
    after every generation and ``out/rule.json`` (a student file, usable as ``--evaluator
    student:out/rule.json``): the distribution's mean after every generation, and the
    selected mean (``choose``) with its selection result at the end. The checkpoint is also
    written after each checked mean, so a stopped selection resumes too. The floors run on
    ``workers`` local processes, or on Ray actors with ``ray`` ("local" or a cluster's
    address; ``training.runs.runner.open_backend``)."""
    state: SearchState = search.start(
        out, config, resume,
        lambda: SearchState(0, new_strategy(config, search_dimension(config, case.crew_types)),
                            config=config.model_dump()))
    state.checked = getattr(state, "checked", {})  # a checkpoint from before select_every
    limit = config.max_time_s or case.simulation.max_time_s
    popsize = state.es.popsize
    crew_types = sorted(case.crew_types)
    done = (len(state.baseline) + state.generation * popsize * config.seeds_per_generation
            + len(set(state.checked) & set(generations_checked(config)))
            * len(config.select_seeds))
    bar = search.progress_bar(total_episodes(config, popsize), done, "floor", "rule search",
                              progress)
    names = student_features(config)
    floors = {f: (case, config.stall_s, config.max_time_s, False, None, f,
                  search_calibration(case, config) if f == "event" else None)
              for f in {config.fidelity, config.select_fidelity}}
    same = config.fidelity == config.select_fidelity

    with search.episodes(_rule_job, floors[config.fidelity], workers, ray, bar, state) as play:
        need = [s for s in sorted(set(config.train_seeds)
                                  | (set(config.select_seeds) if same else set()))
                if s not in state.baseline]
        for row in play([(None, config.candidates, s, config.navigator) for s in need]):
            state.baseline[row["seed"]] = row["makespan_s"]
        while state.generation < config.generations:
            seeds = generation_seeds(config, state.generation)
            xs = state.es.ask()
            jobs = [(rule_weights(config, x, crew_types), config.candidates, s,
                     config.navigator, names) for x in xs for s in seeds]
            rows = play(jobs)
            n = len(seeds)
            base = [state.baseline[s] for s in seeds]
            fits = [paired_fitness([r["makespan_s"] for r in rows[k * n:(k + 1) * n]], base,
                                   limit) for k in range(len(xs))]
            state.es.tell(xs, fits)
            state.generation += 1
            state.log.append({"generation": state.generation, "episodes": state.evaluations,
                              "best": min(fits), "mean": float(np.mean(fits)),
                              "sigma": float(state.es.sigma), "seeds": seeds,
                              "mean_x": [float(v) for v in state.es.mean]})
            bar.set_postfix_str(f"gen {state.generation}, best {min(fits):+.0f} s", refresh=True)
            _record(state, out, config, crew_types, popsize)
    with search.episodes(_rule_job, floors[config.select_fidelity], workers, ray, bar,
                         state) as play:
        need = [s for s in config.select_seeds if s not in state.baseline]
        for row in play([(None, config.candidates, s, config.navigator) for s in need]):
            state.baseline[row["seed"]] = row["makespan_s"]
        means = {0: [0.0] * len(state.es.mean),
                 **{row["generation"]: row["mean_x"] for row in state.log}}
        for g in generations_checked(config):
            if g in state.checked:
                continue
            weights = rule_weights(config, means[g], crew_types)
            rows = play([(weights, config.candidates, s, config.navigator, names)
                         for s in config.select_seeds])
            state.checked[g] = selection_result(rows, state.baseline, limit)
            write_atomic(out / search.CHECKPOINT, pickle.dumps(state))
        selection = choose(state, config)  # cheap, and the same for the same checks
        if selection != state.selection:
            state.selection = selection
            _record(state, out, config, crew_types, popsize)
    bar.close()
    return state


def search_calibration(case, config: RuleSearchConfig):
    """The event floor's calibration: ``config.calibration``'s file, or the case's beside it
    (the built-in case's for no case file); a file fitted on another floor is refused."""
    from cmdp_pymunk.eventfloor import calibration_for

    return calibration_for(case, config.case, config.calibration)


def choose(state: SearchState, config: RuleSearchConfig) -> dict:
    """The checked mean with the lowest paired difference to Eq. 9, or Eq. 9 itself (weights
    0, generation 0) when none is below 0; with every checked generation's difference."""
    zeros = [0.0] * (len(state.es.mean) if state.es is not None else len(config.features))
    diffs = {g: r["diff_mean_s"] for g, r in state.checked.items()
             if g in generations_checked(config) and r["diff_mean_s"] is not None}
    best = min(diffs, key=lambda g: (diffs[g], g), default=None)
    if best is None or diffs[best] >= 0:
        return {"generation": 0, "weights": zeros, "diff_mean_s": 0.0,
                "checked": diffs, "note": "no checked mean beat Eq. 9: the rule is Eq. 9"
                + (" plus the start student's weights" if config.start else "")}
    means = {0: zeros, **{row["generation"]: row["mean_x"] for row in state.log}}
    return {"generation": best, "weights": list(means[best]), **state.checked[best],
            "checked": diffs}


def selection_result(rows: list[dict], baseline: dict, limit_s: float) -> dict:
    """The searched rule against Eq. 9 on the selection seeds: the paired mean difference with
    its 95 % interval (``training.runs.paired.paired``), the ratio of mean makespans, and how
    many floors either left unfinished."""
    from training.runs.paired import paired

    mine = [{"seed": r["seed"], "finished": r["finished"], "makespan_s": r["makespan_s"]}
            for r in rows]
    ref = [{"seed": s, "finished": baseline[s] is not None, "makespan_s": baseline[s]}
           for s in (r["seed"] for r in rows)]
    result = paired(mine, ref)
    result["seeds"] = [r["seed"] for r in rows]
    result["unfinished"] = sum(not r["finished"] for r in rows) + sum(
        not x["finished"] for x in ref)
    return result


def _record(state: SearchState, out: Path, config: RuleSearchConfig, crew_types,
            popsize: int) -> None:
    """history.csv, rule.json (the distribution's mean) and the checkpoint, each atomically."""
    search.write_history(
        out, "generation,episodes,best_paired_s,mean_paired_s,sigma,"
        + ",".join(f"w_{name}" for name in search_names(config, crew_types)),
        [f"{r['generation']},{r['episodes']},{r['best']:.1f},{r['mean']:.1f},{r['sigma']:.4f},"
         + ",".join(f"{v:.4f}" for v in r["mean_x"]) for r in state.log])
    x = state.selection["weights"] if state.selection else state.es.mean
    rule = StudentEvaluator(rule_weights(config, x, crew_types), config.candidates,
                            student_features(config))
    rule.save(out / "rule.json", {
        "made_by": "training.search.rule (CMA-ES, paired makespan against Eq. 9)",
        "searched": dict(zip(search_names(config, crew_types), (round(float(v), 6) for v in x),
                             strict=True)),
        "start": config.start,
        "generation": state.selection["generation"] if state.selection else state.generation,
        "generations_run": state.generation, "popsize": popsize,
        "train_seeds": config.train_seeds, "seeds_per_generation": config.seeds_per_generation,
        "fidelity": config.fidelity, "select_fidelity": config.select_fidelity,
        "selection": state.selection})
    write_atomic(out / search.CHECKPOINT, pickle.dumps(state))
