"""How much of a teacher's label is the future's noise? (``python -m training.research.distill
noise``)

A lookahead label says which of Eq. 9's best candidates finished the floor first in the
teacher's branches: one future each (the expected paces, or the floor's own). A student can
learn only what would hold in *other* futures too. On the floors a label run kept
(``--states``), this replays each sampled decision's candidates in the teacher's own future
(a check: the makespans must come back) and in ``futures`` sampled futures, the same for every
candidate of a decision (paired, as the lookahead's), and reports:

- how often two futures agree on the best candidate, and the teacher with each future;
- the candidates' makespan minus the first's (Eq. 9's choice) in each future: mean, SD, and
  the correlation between futures;
- how many differences exceed ``LARGE_S`` in two futures with the same sign, and with
  opposite signs (clear mistakes every future shows would be the first);
- the difference split into what every future shares (``signal_sd_s``: the square root of the
  covariance between two futures' differences) and what each future adds on its own
  (``noise_sd_s``: the SD of the two futures' differences minus each other, over sqrt 2).

Scenario keys of the sampled futures depend on the seed, the decision and the future only, so
a run repeats exactly.
"""

from __future__ import annotations

import functools
import itertools
import json
import math
import pickle
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from agents.lookahead import LookaheadSettings, run_branch
from agents.specs import make_lookahead
from cmdp_pymunk.evaluate import PriorityEvaluator
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.streams import EXPECTED
from training.runs.backends import open_backend

LARGE_S = 500.0  # a candidate difference this large is a clear call in its future
SCENARIO_BASE = 5_000_000  # far from the keys the lookahead draws (decision x futures)


def scenario_key(seed: int, row: int, future: int) -> int:
    """The sampled future ``future`` of label row ``row`` on ``seed``'s floor."""
    return SCENARIO_BASE + 100_003 * future + 1_009 * seed + row


def teacher_future(teacher: str):
    """The future the teacher's branches ran in (``streams.EXPECTED`` or None: the floor's
    own), or ``False`` for a sampled-futures teacher, whose branches cannot be replayed here.
    ``teacher``: a label file's spec, ``lookahead:candidates=K+futures=F``."""

    settings = make_lookahead(teacher.partition(":")[2]).settings
    if settings.expected_paces:
        return EXPECTED
    return None if settings.futures == 0 else False


def load_states(path: Path) -> list[tuple]:
    """The decisions' floors of a ``seed-N.states.pkl`` (``decision_state``), in row order."""

    with open(path, "rb") as f:
        blobs = pickle.load(f)
    states = [pickle.loads(b) for b in blobs]
    if any(len(s) != 4 for s in states):
        raise ValueError(f"{path}: not (engine, low level, crew, candidates) per decision "
                         "(written by an older commit); fix: label again with --states")
    return states


@functools.lru_cache(maxsize=2)  # a worker serves the rows of one floor in turn
def _states(path: str) -> list[tuple]:
    return load_states(Path(path))


def candidate_makespan(path: str, row: int, k: int, scenario) -> float:
    """Candidate ``k`` of decision ``row`` of a ``.states.pkl``, played to the end by Eq. 9 in
    future ``scenario``, with the teacher's low level (``decision_state``)."""

    engine, low_level, i, candidates = _states(path)[row]
    base = PriorityEvaluator()  # the labelling lookahead's base (``distill.label_floor``)
    values = base.values_for(engine, i)
    branch = engine.clone(scenario, keep_log=False)
    return run_branch(branch, low_level, base, i, values, candidates[k],
                      LookaheadSettings().unfinished_penalty_s)


def _job(runner, path, row, k, scenario):
    return candidate_makespan(path, row, k, scenario)


def plan(folder: Path, every: int, futures: int) -> tuple[list[tuple], list[tuple], dict]:
    """The branches to run: (states path, row, candidate, scenario) jobs, their keys
    (seed, row, future: "teacher" or an int, candidate), and each seed's label arrays."""
    files = sorted(folder.glob("seed-*.npz"), key=lambda p: int(p.stem.split("-")[1]))
    labels, jobs, keys = {}, [], []
    for f in files:
        states = f.with_name(f.stem + ".states.pkl")
        if not states.exists():
            continue
        data = np.load(f)
        seed = int(data["seed"])
        labels[seed] = data
        own = teacher_future(str(data["teacher"]))
        for row in range(0, len(data["choice"]), every):
            n = int((~np.isnan(data["makespan_s"][row])).sum())
            for future, k in itertools.product(["teacher", *range(futures)], range(n)):
                if future == "teacher":
                    if own is False:
                        continue
                    scenario = own
                else:
                    scenario = scenario_key(seed, row, future)
                jobs.append((str(states), row, k, scenario))
                keys.append((seed, row, future, k))
    if not labels:
        raise ValueError(f"{folder}: no seed-N.states.pkl beside the label files; make them with "
                         f"`python -m training.research.distill label --states --out {folder}`")
    return jobs, keys, labels


def summarize(keys: list[tuple], makespans: list[float], labels: dict, futures: int) -> dict:
    """The report of the module doc from every branch's makespan."""
    by: dict = {}
    for (seed, row, future, k), m in zip(keys, makespans, strict=True):
        by.setdefault((seed, row), {}).setdefault(future, {})[k] = m
    replayed = exact = 0
    agree_futures, agree_teacher = [], []
    diffs = [[] for _ in range(futures)]
    for (seed, row), runs in sorted(by.items()):
        label = labels[seed]["makespan_s"][row]
        n = int((~np.isnan(label)).sum())
        if "teacher" in runs:
            replayed += n
            exact += sum(bool(runs["teacher"][k] == label[k]) for k in range(n))
        table = np.array([[runs[f][k] for k in range(n)] for f in range(futures)])
        best = table.argmin(axis=1)
        agree_futures += [bool(best[a] == best[b])
                          for a, b in itertools.combinations(range(futures), 2)]
        agree_teacher += [bool(b == int(labels[seed]["choice"][row])) for b in best]
        for f in range(futures):
            diffs[f] += list(table[f, 1:] - table[f, 0])
    d = np.array(diffs)
    report = {"decisions": len(by), "futures": futures, "branches": len(makespans),
              "replayed_candidates": replayed, "replayed_exactly": exact,
              "agree_teacher_future": round(float(np.mean(agree_teacher)), 3),
              "difference_mean_s": [round(float(x), 1) for x in d.mean(axis=1)],
              "difference_sd_s": [round(float(x), 1) for x in d.std(axis=1)]}
    if futures >= 2 and d.shape[1] >= 2:
        pairs = list(itertools.combinations(range(futures), 2))
        with np.errstate(invalid="ignore", divide="ignore"):  # constant differences: None
            cov = np.mean([np.cov(d[a], d[b])[0, 1] for a, b in pairs])
            corr = np.mean([np.corrcoef(d[a], d[b])[0, 1] for a, b in pairs])
        own = np.mean([np.var(d[a] - d[b], ddof=1) / 2 for a, b in pairs])
        large = [(abs(d[a]) > LARGE_S) & (abs(d[b]) > LARGE_S) for a, b in pairs]
        same = [x & (np.sign(d[a]) == np.sign(d[b]))
                for x, (a, b) in zip(large, pairs, strict=True)]
        report.update({
            "agree_two_futures": round(float(np.mean(agree_futures)), 3),
            "large_same_sign": round(float(np.mean([x.mean() for x in same])), 3),
            "large_opposite_sign": round(float(np.mean(
                [(x & ~y).mean() for x, y in zip(large, same, strict=True)])), 3),
            "difference_correlation": _finite(corr, 3),
            "signal_sd_s": round(math.sqrt(max(cov, 0.0)), 1),
            "noise_sd_s": round(math.sqrt(own), 1)})
    return report


def _finite(x, digits: int):
    """``x`` rounded, or None where it is not a number (a correlation of a constant)."""
    return round(float(x), digits) if np.isfinite(x) else None


def noise(args) -> int:


    if args.every < 1 or args.futures < 1:
        raise ValueError(f"--every {args.every} --futures {args.futures}: both must be >= 1")
    jobs, keys, labels = plan(Path(args.labels), args.every, args.futures)
    makespans: list = [None] * len(jobs)
    with tqdm(total=len(jobs), unit="branch", desc="noise", file=sys.stderr) as bar, \
            open_backend(_job, None, args.workers or None) as pool:
        for n, makespan in pool.as_completed(jobs):
            makespans[n] = makespan
            bar.update(1)
    report = {"command": "python -m training.research.distill " + " ".join(args.argv),
              "labels": str(args.labels), "seeds": sorted(labels),
              **summarize(keys, makespans, labels, args.futures)}
    print(json.dumps(report, indent=1))
    if args.out:  # with every branch, for analyses the summary does not make
        report["branches_s"] = [[*key, m] for key, m in zip(keys, makespans, strict=True)]
        write_atomic(Path(args.out), json.dumps(report) + "\n")
    return 0
