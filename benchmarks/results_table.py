"""The benchmark table: every registered variant x strategy over many seeds, makespan and return,
with the mean and its t interval beside the interquartile mean (IQM) and its bootstrap interval.

    python benchmarks/results_table.py [--ids cmdp/TinyFloor-v1,...] [--seeds 0-9]
        [--strategies random,nearest,priority,ga:models/ga_priorities.json,...]
        [--workers 2] [--out out/bench_table]

Each episode: ``pettingzoo.make("parallel", ID, evaluator=...)`` with the scripted navigator
(``blind=True, park_idle=True``, as ``cmdp-simulate`` runs it: no rays cast, idle seconds
skipped), to the end of the floor or the variant's time limit. A strategy values the targets:
``random`` draws each target's value uniformly from [0.5, 1] at every evaluation (its own
generator per seed), the others are ``--evaluator`` specs (``agents.specs``). A strategy that
does not fit a variant (a GA file or a model made for another case) is left out of that
variant's table with the reason.

Per episode two returns, each the sum over the episode's steps averaged over the crews: the
env's reward, the reaching reward R_r (Eqs. 6-7), and ``infos[agent]["evaluation_reward"]``,
the evaluation reward R_e (Eq. 5) the high level is trained on.

Statistics over the seeds (finished floors only for the makespan): the mean with its 95 %
Student-t interval (``training.runs.paired.mean_ci``), and the interquartile mean (the mean of
the middle 50 %: ``scipy.stats.trim_mean(x, 0.25)``, rliable's ``aggregate_iqm``) with a 95 %
percentile-bootstrap interval over the seeds (2,000 resamples, a fixed generator), the
interval rliable's ``get_interval_estimates`` gives for one task. rliable itself (1.2.0) is
not used: it needs ``arch<8``, and arch 7.2 fails to import beside pandas 3 (which OR-Tools
pulls in here), while arch 8 breaks rliable's bootstrap (``random_state`` is refused).

Writes ``OUT/episodes.csv`` (one row per variant, strategy and seed), ``OUT/table.md`` and
``OUT/table.json``, atomically; prints the table. docs/results.md holds a run's makespans,
docs/research-log.md its whole output.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from contextlib import nullcontext
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_STRATEGIES = ("random", "nearest", "priority", "ga:models/ga_priorities.json",
                      "student:models/searched_rule.json")
BOOTSTRAP_REPS = 2000


class RandomEvaluator:
    """Random target values: each target in scope worth a uniform draw from [0.5, 1] at each
    evaluation (0 is kept for objects out of scope, as Eq. 3 reads it)."""

    def __init__(self, seed: int):
        self.rng = np.random.default_rng([seed, 0x5EED])

    def target_values(self, crew, site, position):
        draws = self.rng.uniform(0.5, 1.0, len(crew.scope))
        return {t: float(v) for t, v in zip(crew.scope, draws, strict=True)}


def make_strategy(spec: str, seed: int):
    from agents.specs import evaluator_from_spec

    return RandomEvaluator(seed) if spec == "random" else evaluator_from_spec(spec)


def play(env_id: str, spec: str, seed: int) -> dict:
    """One episode of ``spec`` on ``env_id``: makespan (None if not finished) and returns."""
    import pettingzoo
    import torch

    import cmdp_pymunk  # noqa: F401  (registers the variants)
    from agents.navigator import Navigator

    torch.set_num_threads(1)
    evaluator = make_strategy(spec, seed)
    env = pettingzoo.make("parallel", env_id, seed=seed, evaluator=evaluator, blind=True,
                          park_idle=True)
    observations, _ = env.reset(seed=seed)
    navigator = Navigator()
    reaching = evaluation = 0.0
    start = time.perf_counter()
    while env.agents:
        observations, rewards, _, _, infos = env.step(env.agent_actions(navigator, observations))
        reaching += sum(rewards.values())
        evaluation += sum(i.get("evaluation_reward", 0.0) for i in infos.values())
    site = env.engine.site
    n = len(site.crews)
    return {"id": env_id, "strategy": spec, "seed": seed, "finished": bool(site.done),
            "makespan_s": env.makespan_s if site.done else None,
            "tasks_ended": site.tasks_ended, "simulated_s": site.time_s,
            "return_reaching": reaching / n, "return_evaluation": evaluation / n,
            "wall_s": round(time.perf_counter() - start, 2)}


def fits(env_id: str, spec: str) -> str:
    """"" if the strategy can run on the variant, else why not (one line)."""
    import pettingzoo

    import cmdp_pymunk  # noqa: F401

    try:
        evaluator = make_strategy(spec, 0)
        env = pettingzoo.make("parallel", env_id, seed=0, evaluator=evaluator, blind=True)
        env.reset(seed=0)
    except (ValueError, OSError) as err:
        return str(err).splitlines()[0]
    return ""


def iqm(values) -> float:
    """The interquartile mean: the mean of the middle 50 % (rliable's ``aggregate_iqm``)."""
    from scipy import stats

    return float(stats.trim_mean(np.asarray(values, dtype=float), 0.25, axis=None))


def bootstrap_ci(values, statistic=iqm, reps: int = BOOTSTRAP_REPS,
                 seed: int = 0) -> tuple[float, float] | None:
    """95 % percentile-bootstrap interval of ``statistic`` over resampled runs; None for
    fewer than 2 values."""
    x = np.asarray(values, dtype=float)
    if len(x) < 2:
        return None
    rng = np.random.default_rng(seed)
    draws = [statistic(x[rng.integers(0, len(x), len(x))]) for _ in range(reps)]
    lo, hi = np.percentile(draws, [2.5, 97.5])
    return float(lo), float(hi)


def describe(values) -> dict:
    from training.runs.paired import mean_ci

    mean, _, ci = mean_ci(values)
    out = {"n": len(values), "mean": mean, "ci95": ci,
           "iqm": iqm(values) if values else None, "iqm_ci95": bootstrap_ci(values)}
    return out


def summarize(rows: list[dict]) -> dict:
    """Per variant, per strategy: finished count and the statistics of makespan and returns."""
    table: dict = {}
    for r in rows:
        table.setdefault(r["id"], {}).setdefault(r["strategy"], []).append(r)
    return {env_id: {spec: {"episodes": len(group),
                            "finished": sum(r["finished"] for r in group),
                            "makespan_s": describe([r["makespan_s"] for r in group
                                                    if r["finished"]]),
                            "return_reaching": describe([r["return_reaching"] for r in group]),
                            "return_evaluation": describe([r["return_evaluation"]
                                                           for r in group])}
                     for spec, group in by_strategy.items()}
            for env_id, by_strategy in table.items()}


def _cell(d: dict, digits: int) -> tuple[str, str]:
    if d["mean"] is None:
        return "-", "-"
    mean = f"{d['mean']:,.{digits}f}"
    if d["ci95"] is not None:
        mean += f" ± {d['ci95']:,.{digits}f}"
    iqm_text = f"{d['iqm']:,.{digits}f}"
    if d["iqm_ci95"]:
        iqm_text += f" [{d['iqm_ci95'][0]:,.{digits}f}, {d['iqm_ci95'][1]:,.{digits}f}]"
    return mean, iqm_text


def markdown(summary: dict, skipped: dict) -> str:
    lines = []
    for env_id, by_strategy in summary.items():
        lines += [f"### `{env_id}`", "",
                  "| strategy | finished | makespan (s): mean ± t 95 % | IQM [bootstrap 95 %] "
                  "| return R_r: mean ± t 95 % | IQM [bootstrap 95 %] "
                  "| return R_e: mean ± t 95 % | IQM [bootstrap 95 %] |",
                  "|---|---|---|---|---|---|---|---|"]
        for spec, e in by_strategy.items():
            cells = [*_cell(e["makespan_s"], 0), *_cell(e["return_reaching"], 2),
                     *_cell(e["return_evaluation"], 2)]
            lines.append(f"| {spec} | {e['finished']}/{e['episodes']} | " + " | ".join(cells)
                         + " |")
        for spec, why in skipped.get(env_id, {}).items():
            lines.append(f"\n`{spec}` left out: {why}")
        lines.append("")
    return "\n".join(lines)


def _registered_ids() -> list[str]:
    from cmdp_pymunk.adapters import registry

    return list(registry.VARIANTS)  # the generated layouts included


def main(argv: list[str] | None = None) -> int:
    import cmdp_pymunk
    from cmdp_pymunk.events import write_atomic
    from training.cli import seed_list, spec_list
    from training.runs.paired import csv_text

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--ids", type=spec_list, default=None,
                   help="comma-separated registered ids (default: every one)")
    p.add_argument("--seeds", type=seed_list, default=list(range(10)))
    p.add_argument("--strategies", type=spec_list, default=list(DEFAULT_STRATEGIES))
    p.add_argument("--workers", type=int, default=2, help="processes (1: this one)")
    p.add_argument("--out", type=Path, default=Path("out/bench_table"))
    args = p.parse_args(argv)
    ids = args.ids or _registered_ids()
    unknown = sorted(set(ids) - set(_registered_ids()))
    if unknown:
        print(f"results_table: unknown id(s) {', '.join(unknown)}; fix: one of "
              f"{', '.join(_registered_ids())}", file=sys.stderr)
        return 2
    skipped: dict = {}
    jobs = []
    for env_id in ids:
        for spec in args.strategies:
            why = fits(env_id, spec)
            if why:
                skipped.setdefault(env_id, {})[spec] = why
            else:
                jobs += [(env_id, spec, seed) for seed in args.seeds]
    print(f"results_table: {len(jobs)} episodes ({len(ids)} variants, {len(args.seeds)} seeds, "
          f"{args.workers} workers)", flush=True)
    start = time.perf_counter()
    rows = []
    with ProcessPoolExecutor(args.workers) if args.workers > 1 else nullcontext() as pool:
        episodes = (pool.map if pool else map)(play, *zip(*jobs, strict=True))
        for k, row in enumerate(episodes, 1):
            rows.append(row)
            if k % 10 == 0 or k == len(jobs):
                print(f"  {k}/{len(jobs)} episodes, {time.perf_counter() - start:.0f} s",
                      flush=True)
    summary = summarize(rows)
    table = markdown(summary, skipped)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                            capture_output=True, text=True).stdout.strip()
    header = (f"Command: `python benchmarks/results_table.py {' '.join(argv or sys.argv[1:])}`; "
              f"commit `{commit}`; {platform.machine()} {platform.system()}, "
              f"{os.cpu_count()} CPUs, {len(jobs)} episodes in "
              f"{time.perf_counter() - start:.0f} s.\n\n")
    args.out.mkdir(parents=True, exist_ok=True)
    write_atomic(args.out / "episodes.csv", csv_text(rows, list(rows[0])))
    write_atomic(args.out / "table.json", json.dumps({"summary": summary, "skipped": skipped},
                                                     indent=1) + "\n")
    write_atomic(args.out / "table.md", header + table)
    print(header + table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
