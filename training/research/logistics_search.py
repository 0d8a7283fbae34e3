"""Learn when a fetching crew asks for the next lift (issue 42 item 6): a linear rule over the
floor's state (``cmdp_pymunk.logistics.Learned``) searched by CMA-ES (the ``cma`` library) for
the lowest mean makespan of the stage-2 target policy on event floors, common random numbers.

    python -m training.research.logistics_search --seeds 3000-3059 --select 3100-3139 \\
        --out models/logistics_learned.json

Why a search over whole floors, not labels of single decisions: a lift decision's effect on
the makespan sits under the floor's chaos after it (about 1,100 s between two candidates of
one decision in one future, PITFALLS), so a one-decision label is close to a coin flip and
needs dozens of futures; a candidate rule scored on the mean of many whole event floors on the
same seeds (common random numbers: every rule meets the same paces) averages that noise over
all of a floor's ~100 decisions at once, and costs about 0.1 s a floor on one core.

Data flow: the rule starts as ``CraneIdle`` (lift when the crane has nothing under way or
queued: bias 0.5, -1 on ``crane_busy`` and on ``crane_queue``); CMA-ES proposes weight
vectors; each is scored by the mean makespan over the training seeds (event floor, target
policy ``--evaluator``); the best rule seen is compared on the selection seeds, paired, with
``CraneIdle``, the reorder point at half a lift and ``Never`` (c7), and written with the
command, config and the selection numbers in its ``meta`` (and the search's history beside
it, ``<out>.history.csv``). The evaluator is the policy-iteration student that the committed
SB3 model plays to the second (``models/README.md``): the same choices without torch.
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import cma
import numpy as np

import cmdp_pymunk
from agents.specs import evaluator_from_spec
from cmdp_pymunk import add_version_flag
from cmdp_pymunk.eventfloor import EventFloor, calibration_for
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.logistics import CraneIdle, Learned, Never, ReorderPoint
from cmdp_pymunk.report import versions
from training.cli import seed_list
from training.runs.paired import paired

FEATURES = ("material=rebars", "material=templates", "material=struts", "stock_lifts",
            "crane_busy", "crane_queue", "fetching_here")
# CraneIdle in these features: lift iff 0.5 - crane_busy - crane_queue > 0 (a bias per material)
START = {"material=rebars": 0.5, "material=templates": 0.5, "material=struts": 0.5,
         "crane_busy": -1.0, "crane_queue": -1.0}


@dataclass
class SearchConfig:
    """The search's arguments (``--help`` says each)."""

    seeds: list[int]
    select: list[int]
    out: Path
    evaluator: str = "student:models/api_student_r4.json"
    features: tuple[str, ...] = FEATURES
    shares: tuple[float, ...] = (0.75, 0.5, 0.25)
    generations: int = 5
    popsize: int = 8
    sigma0: float = 0.5
    seed: int = 0
    stall_s: float = 3600.0
    command: str = field(default="")


def makespans(case, calibration, evaluator, role, seeds) -> list[dict]:
    """One event floor per seed under ``role``: ``{"seed", "finished", "makespan_s"}`` rows
    (makespan None if a floor did not finish)."""
    floor = EventFloor(case, evaluator=evaluator, stall_s=3600.0, calibration=calibration,
                       logistics=role)
    rows = []
    for seed in seeds:
        floor.reset(seed)
        floor.run()
        rows.append({"seed": seed, "finished": floor.site.done,
                     "makespan_s": floor.makespan_s if floor.site.done else None})
    return rows


def mean_makespan(rows: list[dict]) -> float:
    """The search's objective: mean makespan, an unfinished floor counted as infinite."""
    values = [r["makespan_s"] for r in rows]
    return math.inf if any(v is None for v in values) else float(np.mean(values))


def rule_of(config: SearchConfig, x) -> Learned:
    """The rule a search vector stands for: ``x`` = (weights..., ) with the material one-hots
    as per-material biases (the rule's own bias 0)."""
    return Learned.from_weights(config.features, [float(v) for v in x], 0.0, config.shares)


def search(config: SearchConfig, log=print) -> tuple[Learned, list[dict], dict]:
    """CMA-ES over the rule's weights on the training seeds; then the best rule seen against
    the shipped roles on the selection seeds. Returns the rule, the search's history (one row
    a candidate) and the selection's paired numbers."""
    case = cmdp_pymunk.load_case(None)
    calibration = calibration_for(case)
    evaluator = evaluator_from_spec(config.evaluator)
    x0 = [START.get(f, 0.0) for f in config.features]
    es = cma.CMAEvolutionStrategy(x0, config.sigma0, {
        "popsize": config.popsize, "seed": config.seed + 1,  # cma: seed 0 means "from time"
        "maxiter": config.generations, "verbose": -9})
    history: list[dict] = []
    start_rows = makespans(case, calibration, evaluator, rule_of(config, x0), config.seeds)
    best = (mean_makespan(start_rows), list(x0))
    history.append({"generation": 0, "candidate": 0, "mean_makespan_s": best[0],
                    **dict(zip(config.features, x0, strict=True))})
    log(f"start (CraneIdle): {best[0]:,.1f} s on {len(config.seeds)} seeds")
    generation = 0
    while not es.stop():
        generation += 1
        xs = es.ask()
        scores = []
        for k, x in enumerate(xs):
            score = mean_makespan(makespans(case, calibration, evaluator, rule_of(config, x),
                                            config.seeds))
            scores.append(score if math.isfinite(score) else 1e9)
            history.append({"generation": generation, "candidate": k, "mean_makespan_s": score,
                            **dict(zip(config.features, map(float, x), strict=True))})
            if score < best[0]:
                best = (score, [float(v) for v in x])
        es.tell(xs, scores)
        log(f"generation {generation}: best {min(scores):,.1f} s, best so far {best[0]:,.1f} s")
    rule = rule_of(config, best[1])
    roles = {"learned": rule, "crane-idle": CraneIdle(), "reorder": ReorderPoint(lifts=0.5),
             "never": Never()}
    rows = {name: makespans(case, calibration, evaluator, role, config.select)
            for name, role in roles.items()}
    selection = {}
    for name in ("crane-idle", "reorder", "never"):
        vs = paired(rows["learned"], rows[name])
        selection[f"learned_vs_{name}_s"] = [  # mean and interval (None: one seed)
            None if v is None else round(v, 1) for v in (vs["diff_mean_s"], vs["diff_ci95_s"])]
    selection["mean_makespan_s"] = {n: round(mean_makespan(r), 1) for n, r in rows.items()}
    selection["train_mean_makespan_s"] = {"start_crane_idle": round(history[0]
                                                                    ["mean_makespan_s"], 1),
                                          "learned": round(best[0], 1)}
    log(f"selection seeds: {selection}")
    return rule, history, selection


def history_csv(history: list[dict]) -> str:
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=list(history[0]))
    writer.writeheader()
    writer.writerows(history)
    return out.getvalue()


def parse(argv) -> SearchConfig:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_version_flag(p)
    p.add_argument("--seeds", required=True, help="training seeds, e.g. 3000-3059")
    p.add_argument("--select", required=True, help="selection seeds, e.g. 3100-3139")
    p.add_argument("--out", required=True, type=Path, help="the model file (JSON)")
    p.add_argument("--evaluator", default=SearchConfig.evaluator,
                   help="the target policy the rule is fitted under (an evaluator spec)")
    p.add_argument("--generations", type=int, default=SearchConfig.generations)
    p.add_argument("--popsize", type=int, default=SearchConfig.popsize)
    p.add_argument("--sigma0", type=float, default=SearchConfig.sigma0)
    p.add_argument("--seed", type=int, default=SearchConfig.seed, help="CMA-ES's seed")
    a = p.parse_args(argv)
    seeds, select = seed_list(a.seeds), seed_list(a.select)
    if set(seeds) & set(select):
        p.error(f"--seeds and --select share seeds {sorted(set(seeds) & set(select))[:5]}; "
                "fix: give them ranges of their own")
    if a.generations < 1 or a.popsize < 2 or not a.sigma0 > 0:
        p.error("fix: --generations 1 or more, --popsize 2 or more, --sigma0 above 0")
    return SearchConfig(seeds, select, a.out, a.evaluator, generations=a.generations,
                        popsize=a.popsize, sigma0=a.sigma0, seed=a.seed,
                        command="python -m training.research.logistics_search " +
                        " ".join(argv))


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    config = parse(argv)
    start = time.process_time()
    rule, history, selection = search(config, log=lambda m: print(m, flush=True))
    meta = {"command": config.command, "versions": versions(),
            "config": {k: (str(v) if isinstance(v, Path) else v)
                       for k, v in asdict(config).items() if k != "command"},
            "selection": selection, "cpu_s": round(time.process_time() - start, 1)}
    write_atomic(config.out.with_suffix(".history.csv"), history_csv(history))
    write_atomic(config.out, rule.to_json(meta))
    print(f"wrote {config.out} ({meta['cpu_s']} s CPU)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
