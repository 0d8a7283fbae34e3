"""New features for old labels, without the teacher: replay each labelled floor under its
acting policy and compute the candidates' features again at every decision.

    python -m training.research.distill relabel runs/labels_r4 --out runs/labels_r4_all \
        [--features all] [--replace OLD=NEW ...] [--case CASE] [--workers 2]

A policy-iteration label file (``distill label --acting SPEC``) holds a floor that followed
``SPEC``; the teacher only watched. Same case, seed, acting policy and code: the same floor
(determinism), so its decisions come again in the same order, with the same candidates
(the teacher's base ranks them), at a few seconds a floor instead of a minute of branches. Each
replayed decision is checked against the file (crew type, the candidates' Eq. 9 values, and
every feature both sets share) and a floor that went elsewhere is refused, naming the file and
the decision: the policy file or the simulator changed since. The teacher's makespans and
choice are copied unchanged; the features are those of ``--features``.

A file whose floor the lookahead drove itself (labelled without ``--acting``) cannot be
replayed without running it again, and is refused. ``--replace OLD=NEW`` rewrites a path
in the stored acting and teacher specs (a policy file that moved since).
"""

from __future__ import annotations

import time

import numpy as np

import cmdp_pymunk
from agents.features import FEATURE_NAMES, FloorFacts, candidate_features
from agents.lookahead import LookaheadEvaluator
from agents.navigator import Navigator
from agents.specs import evaluator_from_spec, make_lookahead
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.evaluate import PriorityEvaluator
from cmdp_pymunk.rollout import run_episode
from training.research.labelling import CandidatesOnly, Labeller


def replace_specs(text: str, replace: list[tuple[str, str]]) -> str:
    for old, new in replace:
        text = text.replace(old, new)
    return text


def replace_option(text: str) -> tuple[str, str]:
    """``--replace OLD=NEW``."""
    old, sep, new = text.partition("=")
    if not sep or not old or not new:
        raise ValueError(f"--replace {text!r}: give OLD=NEW, e.g. "
                         "/old/models/rule.json=models/rule.json")
    return old, new


def relabel_floor(path: str, features: tuple[str, ...],
                  replace: list[tuple[str, str]] = (), case_path: str | None = None) -> dict:
    """The arrays of label file ``path`` with the candidates' ``features`` computed again on
    the replayed floor (module doc); ValueError where the floor cannot be replayed or went
    elsewhere. ``case_path``: the case the labels were made on (None: the built-in one)."""

    old = dict(np.load(path))
    acting = replace_specs(str(old.get("acting", "")), replace)
    teacher = replace_specs(str(old.get("teacher", "")), replace)
    if not acting:
        raise ValueError(f"{path}: its floor followed the lookahead itself (labelled without "
                         "--acting): it cannot be replayed without the teacher; fix: label it "
                         "again with --features")
    old_names = tuple(str(n) for n in old["feature_names"]) if "feature_names" in old \
        else FEATURE_NAMES
    spec = make_lookahead(teacher.partition(":")[2])
    candidates = old["values"].shape[1]

    navigator = Navigator()
    # the lookahead's candidates at each decision of the acting policy's floor, no branches
    replay = Labeller(CandidatesOnly(LookaheadEvaluator(spec.base, spec.settings,
                                                        low_level=navigator)),
                      acting=evaluator_from_spec(acting))
    engine = Engine(cmdp_pymunk.load_case(case_path), evaluator=replay, park_idle=True)
    priority = PriorityEvaluator()
    facts: list = []
    shared = [n for n in features if n in old_names]
    phi = np.zeros((len(old["choice"]), candidates, len(features)))

    def record(engine, i, values, decision) -> None:
        r = len(replay.decisions) - 1
        site = engine.site
        if not facts:
            facts.append(FloorFacts.of(site))
        crew = site.crews[i]
        priorities = priority.priorities(crew, site, engine.positions[i])
        m = len(decision.candidates)
        if r >= len(old["choice"]):
            raise ValueError(f"{path}: the replayed floor has more decisions than the file's "
                             f"{len(old['choice'])}; {_elsewhere}")
        row = candidate_features(facts[0], crew, site, engine.positions[i],
                                 decision.candidates, priorities, engine.positions, features)
        same = (crew.type == str(old["crew_type"][r])
                and np.allclose([priorities[t] for t in decision.candidates],
                                old["values"][r, :m])
                and np.isnan(old["values"][r, m:]).all()
                and all(np.allclose(row[:, features.index(n)],
                                    old["features"][r, :m, old_names.index(n)]) for n in shared))
        if not same:
            raise ValueError(f"{path}: decision {r} (t = {site.time_s:.0f} s, crew {i}) is not "
                             f"the file's; {_elsewhere}")
        phi[r, :m] = row

    replay.on_decision = record
    start = time.perf_counter()
    run_episode(engine, navigator, int(old["seed"]), stall_s=3600.0, progress=False)
    if len(replay.decisions) != len(old["choice"]):
        raise ValueError(f"{path}: the replayed floor has {len(replay.decisions)} decisions, the "
                         f"file {len(old['choice'])}; {_elsewhere}")
    old["features"] = phi
    old["feature_names"] = np.array(features, dtype="U32")
    return {"path": path, "arrays": old, "wall_s": time.perf_counter() - start,
            "makespan_s": engine.makespan_s}


_elsewhere = ("the floor went elsewhere: the acting policy's file, the case or the simulator "
              "changed since it was labelled (fix: --replace a moved policy file with its "
              "old version, or label the seed again)")


def _relabel_job(runner, path, features, replace, case_path):
    return relabel_floor(path, features, replace, case_path)
