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
from pathlib import Path

import numpy as np


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
    import cmdp_pymunk
    from agents.features import FEATURE_NAMES, FloorFacts, candidate_features
    from agents.lookahead import Decision, LookaheadEvaluator, ranked
    from agents.navigator import Navigator
    from agents.specs import make_evaluator, make_lookahead
    from cmdp_pymunk.engine import Engine
    from cmdp_pymunk.evaluate import PriorityEvaluator
    from cmdp_pymunk.rollout import run_episode
    from cmdp_pymunk.state import ScopeKind

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

    class Replay(LookaheadEvaluator):
        """The lookahead's candidates at each decision of the acting policy's floor, and no
        branches."""

        def _decide(self, engine, i, values):
            order = ranked(values)
            chosen = order[:self.settings.candidates]
            if engine.site.crews[i].scope_kind != ScopeKind.TASKS or len(chosen) < 2:
                return None
            decision = Decision(engine.site.time_s, i, chosen, [np.nan] * len(chosen),
                                order[0], order[0], 0.0, None)
            self.decisions.append(decision)
            self.on_decision(engine, i, values, decision)
            return decision

    navigator = Navigator()
    replay = Replay(spec.base, spec.settings, acting=make_evaluator(acting), low_level=navigator)
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


def relabel(args) -> int:
    from tqdm import tqdm

    import cmdp_pymunk
    from cmdp_pymunk.events import write_atomic
    from training.research.distill import features_option, label_files
    from training.runs.backends import open_backend

    features = features_option(args.features)
    replace = [replace_option(r) for r in args.replace]
    cmdp_pymunk.load_case(args.case)  # a bad case file fails before any floor
    out = Path(args.out)
    files = [f for folder in args.labels for f in label_files(Path(folder))]
    if not files:
        raise ValueError(f"{', '.join(args.labels)}: no seed-N.npz label files")
    if any(f.parent.resolve() == out.resolve() for f in files):
        raise ValueError(f"--out {out}: a label folder it reads; fix: another folder")
    names = [f.name for f in files]
    if len(set(names)) != len(names):
        raise ValueError("two label folders hold the same seed; fix: relabel them into "
                         "separate --out folders")
    todo = [f for f in files if not (out / f.name).exists()]
    print(f"relabel: {len(files) - len(todo)} floors already in {out}; {len(todo)} to go "
          f"({len(features)} features, {args.workers} worker(s))", flush=True)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [(str(f), features, replace, args.case) for f in todo]
    with tqdm(total=len(jobs), unit="floor", desc="relabel") as bar, \
            open_backend(_relabel_job, None, args.workers or None) as pool:
        for _, result in pool.as_completed(jobs):
            import io

            blob = io.BytesIO()
            np.savez_compressed(blob, **result["arrays"])
            write_atomic(out / Path(result["path"]).name, blob.getvalue())
            bar.update(1)
    return 0


def add_parser(sub) -> None:
    r = sub.add_parser("relabel", help="compute other features for existing labels by replaying "
                       "their floors under the acting policy (no teacher)")
    r.add_argument("labels", nargs="+", help="label folder(s) made by `label --acting`")
    r.add_argument("--case", default=None, help="the case the labels were made on (default: "
                   "built-in)")
    r.add_argument("--out", required=True, help="folder for the new label files (resumes)")
    r.add_argument("--features", default="all",
                   help="first, all (ALL_FEATURES, default) or names joined by commas")
    r.add_argument("--replace", action="append", default=[], metavar="OLD=NEW",
                   help="rewrite a path in the files' acting and teacher specs (a moved "
                        "policy file); repeatable")
    r.add_argument("--workers", type=int, default=1, help="worker processes")
