"""The genetic-algorithm baseline of section 5.3: task priorities searched with DEAP.

Genes are one priority per task in [0, 1] (the paper's reference [57]), read by
``TaskPriorityEvaluator``. An individual's fitness, to minimize, follows the paper's words
("minimizing the agent simulation duration and reducing the number of idle agent steps"),
averaged over the training seeds:

    f = mean over seeds of (makespan_s + idle_weight * idle crew-steps)

with an unfinished episode (stalled, time-out, a stuck model) scored as ``2 * max_time_s``.
Episodes run with the same low level as the strategy compared with (``navigator``).

DEAP supplies the machinery: tournament selection, simulated binary crossover and polynomial
mutation, both bounded to [0, 1]; the ``elite`` best individuals pass unchanged. DEAP draws
from Python's ``random`` module (it has no generator argument): the search seeds it, and
saves and restores its state in every checkpoint, so a resumed run continues exactly as the
uninterrupted one. The simulations get their seeds explicitly. An individual whose genes
were already evaluated is not run again (a cache by genes).
"""

from __future__ import annotations

import pickle
import random
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, Strict

from agents.task_priority import TaskPriorityEvaluator
from cmdp_pymunk.events import write_atomic

from ..runs.runner import EpisodeRunner
from . import harness as search

Count = Annotated[int, Strict(), Field(gt=0)]
CountOrZero = Annotated[int, Strict(), Field(ge=0)]
Share = Annotated[float, Strict(), Field(ge=0, le=1, allow_inf_nan=False)]
Positive = Annotated[float, Strict(), Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Strict(), Field(ge=0, allow_inf_nan=False)]


class GAConfig(BaseModel):
    """Every setting of a GA run (``training/configs/ga.toml``; ``--set key=value``)."""

    model_config = ConfigDict(extra="forbid")

    case: str | None = None  # case file; None: the built-in case
    seed: CountOrZero = 0  # the GA's own randomness
    population: Count = 16
    generations: CountOrZero = 6  # after the initial population (0: only that one)
    elite: CountOrZero = 1  # best individuals copied unchanged into the next generation
    tournament_size: Count = 3
    crossover_prob: Share = 0.7  # per pair of offspring
    crossover_eta: Positive = 15.0  # simulated binary crossover's crowding (higher: closer)
    mutation_prob: Share = 0.4  # per offspring
    gene_mutation_prob: Share = 0.1  # per gene of a mutated offspring
    mutation_eta: Positive = 20.0  # polynomial mutation's crowding
    # what the genes add to: "none" (task priority plus distance_weight times closeness) or
    # "priority" (Eq. 9's V' plus the task priority: equal genes rank as the heuristic does)
    base: Literal["none", "priority"] = "none"
    # the initial population: one individual that plays the heuristic's part (base "none":
    # Eq. 9's successor term, all successors / the most of any task; base "priority": every
    # gene 0.5, which is the heuristic itself), the rest uniform in [0, 1]
    seed_successors: bool = True
    train_seeds: Annotated[list[CountOrZero], Field(min_length=1)] = [0, 1, 2]
    idle_weight: NonNegative = 0.01  # seconds of fitness per idle crew-step
    distance_weight: NonNegative = 0.5  # Eq. 9's b2 in the evaluator: nearer wins a tie
    navigator: str = "scripted"  # the low level: scripted, or a stage-1 model .zip
    stall_s: Positive = 3600.0
    max_time_s: Positive | None = None  # None: the case's


def unfinished_makespan_s(max_time_s: float) -> float:
    """What an unfinished episode scores as makespan: twice the time limit."""
    return 2.0 * max_time_s


def episode_fitness(makespan_s: float | None, idle_steps: int, idle_weight: float,
                    max_time_s: float) -> float:
    """One episode's f: makespan + idle_weight * idle crew-steps; an unfinished episode
    (makespan None) scores ``unfinished_makespan_s``."""
    m = makespan_s if makespan_s is not None else unfinished_makespan_s(max_time_s)
    return m + idle_weight * idle_steps


def successor_genes(case) -> list[float]:
    """Eq. 9's first term as genes: each task's transitive successors over the most of any."""
    from cmdp_pymunk.state import Site

    site = Site(case, 2)
    most = max(t.all_successors for t in site.tasks) or 1
    return [t.all_successors / most for t in site.tasks]


def _evaluate_job(runner: EpisodeRunner, genes: tuple, seed: int, distance_weight: float,
                  navigator: str, base: str = "none") -> dict:
    evaluator = TaskPriorityEvaluator.from_genes([t.id for t in runner.case.tasks], genes,
                                                 distance_weight, base)
    return runner.run(evaluator, navigator, seed)


@dataclass
class GAState:
    """Everything a checkpoint holds: the generation done, the population with fitness
    values, the log, the cache of evaluated genes and DEAP's random state."""

    generation: int
    population: list[tuple[tuple, float]]
    log: list[dict]
    cache: dict = field(default_factory=dict)
    random_state: tuple | None = None
    config: dict = field(default_factory=dict)
    evaluations: int = 0

    @property
    def best(self) -> tuple[tuple, float]:
        return min(self.population, key=lambda p: p[1])


def _deap():
    from deap import base, creator, tools

    if not hasattr(creator, "CmdpFitnessMin"):
        creator.create("CmdpFitnessMin", base.Fitness, weights=(-1.0,))
        creator.create("CmdpIndividual", list, fitness=creator.CmdpFitnessMin)
    return creator, tools


def _individual(genes, fitness=None):
    creator, _ = _deap()
    ind = creator.CmdpIndividual(genes)
    if fitness is not None:
        ind.fitness.values = (fitness,)
    return ind


def offspring(population: list, config: GAConfig) -> list:
    """The next generation's new individuals (DEAP: tournament, bounded SBX and polynomial
    mutation, in [0, 1]); fitness invalid where genes changed."""
    from deap import algorithms, base

    _, tools = _deap()
    toolbox = base.Toolbox()
    toolbox.register("mate", tools.cxSimulatedBinaryBounded, eta=config.crossover_eta,
                     low=0.0, up=1.0)
    toolbox.register("mutate", tools.mutPolynomialBounded, eta=config.mutation_eta, low=0.0,
                     up=1.0, indpb=config.gene_mutation_prob)
    chosen = tools.selTournament(population, len(population) - config.elite,
                                 tournsize=config.tournament_size)
    return algorithms.varAnd([toolbox.clone(i) for i in chosen], toolbox,
                             config.crossover_prob, config.mutation_prob)


def run_ga(case, config: GAConfig, out: Path, workers: int | None = 1, resume: bool = False,
           progress: bool = True, ray: str | None = None) -> GAState:
    """Search, writing ``out/checkpoint.pkl`` after every generation, ``out/history.csv`` and
    ``out/best.json`` (the best priority file so far). ``resume`` continues from the
    checkpoint (which must come from the same config, up to ``generations``). The episodes
    run on ``workers`` local processes, or on Ray actors with ``ray`` ("local" or a cluster's
    address; ``training.runs.runner.open_backend``)."""
    state: GAState = search.start(out, config, resume,
                                  lambda: GAState(0, [], [], config=config.model_dump()))
    if resume:
        random.setstate(state.random_state)
    else:
        random.seed(config.seed)
    limit = config.max_time_s or case.simulation.max_time_s
    task_ids = [t.id for t in case.tasks]
    runner_args = (case, config.stall_s, config.max_time_s)
    bar = search.progress_bar(episodes_after(config, config.generations),
                              episodes_after(config, state.generation) if state.population
                              else 0, "episode", "GA", progress)

    def evaluate(genes_list: list[tuple], play) -> list[float]:
        todo = [g for g in dict.fromkeys(genes_list) if g not in state.cache]
        rows = play([(g, s, config.distance_weight, config.navigator, config.base)
                     for g in todo for s in config.train_seeds])
        n = len(config.train_seeds)
        for i, g in enumerate(todo):
            fits = [episode_fitness(r["makespan_s"], r["idle_steps"], config.idle_weight,
                                    limit) for r in rows[i * n:(i + 1) * n]]
            state.cache[g] = float(np.mean(fits))
        bar.update(n * (len(genes_list) - len(todo)))  # cached: counted as done
        return [state.cache[g] for g in genes_list]

    with search.episodes(_evaluate_job, runner_args, workers, ray, bar, state) as pool:
        if not state.population:
            first = successor_genes(case) if config.base == "none" else [0.5] * len(task_ids)
            genes = [tuple(first)] if config.seed_successors else []
            while len(genes) < config.population:
                genes.append(tuple(random.random() for _ in task_ids))
            state.population = list(zip(genes, evaluate(genes, pool), strict=True))
            _record(state, out, case, config, bar)
        while state.generation < config.generations:
            population = [_individual(g, f) for g, f in state.population]
            elite = sorted(population, key=lambda i: i.fitness.values[0])[:config.elite]
            children = offspring(population, config)
            genes = [tuple(min(1.0, max(0.0, float(x))) for x in c) for c in children]
            fits = evaluate(genes, pool)
            state.population = [(tuple(e), e.fitness.values[0]) for e in elite] \
                + list(zip(genes, fits, strict=True))
            state.generation += 1
            _record(state, out, case, config, bar)
    bar.close()
    return state


def episodes_after(config: GAConfig, generation: int) -> int:
    """Episodes played (cached ones counted) once ``generation`` is done: the first
    population, then each generation's offspring (the elite are kept, not replayed), each on
    every training seed."""
    children = config.population - config.elite
    return (config.population + generation * children) * len(config.train_seeds)


def _record(state: GAState, out: Path, case, config: GAConfig, bar) -> None:
    """Log the generation, write the best file and the checkpoint (atomically)."""
    from agents.task_priority import save_priorities

    fits = [f for _, f in state.population]
    best_genes, best = state.best
    state.log.append({"generation": state.generation, "evaluations": state.evaluations,
                      "best": best, "mean": float(np.mean(fits)), "worst": max(fits)})
    bar.set_postfix_str(f"gen {state.generation}, best {best:.0f}", refresh=True)
    search.write_history(out, "generation,episodes,best_fitness,mean_fitness,worst_fitness",
                         [f"{r['generation']},{r['evaluations']},{r['best']:.1f},"
                          f"{r['mean']:.1f},{r['worst']:.1f}" for r in state.log])
    ids = [t.id for t in case.tasks]
    save_priorities(out / "best.json", case, dict(zip(ids, best_genes, strict=True)),
                    config.distance_weight, "ga", config.base, fitness=round(best, 1),
                    generation=state.generation, train_seeds=config.train_seeds,
                    navigator=config.navigator)
    state.random_state = random.getstate()
    write_atomic(out / search.CHECKPOINT, pickle.dumps(state))
