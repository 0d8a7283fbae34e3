"""The labels of ``python -m training.research.distill``: a teacher's decisions on a floor,
written one ``seed-N.npz`` a floor and read back as one set of arrays.

It holds the options that name the teacher and the candidate features (``--candidates``,
``--futures``, ``--teacher``, ``--features``, each checked before any floor runs), the
labelling of one floor under the lookahead (``label_floor``: the lookahead decides, or only
watches an acting policy, and every decision with two or more candidates becomes a row), the
label file (``save_labels``, written whole) and the reading of label folders
(``load_labels``). It is apart from the command line (``distill``) and from the fits
(``distill_fit``, ``distill_model``) because it is what they share: ``label``,
``policy_iteration`` and the Ray benchmark run its floors, and every fit, ``label_cv`` and
``policy_iteration`` read its files. It runs simulations and imports no torch or SB3.
"""

from __future__ import annotations

import io
import pickle
import time
from pathlib import Path

import numpy as np

import cmdp_pymunk
from agents.features import ALL_FEATURES, FEATURE_NAMES, FloorFacts, candidate_features
from agents.lookahead import LookaheadEvaluator
from agents.navigator import Navigator
from agents.specs import evaluator_from_spec, make_lookahead
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.evaluate import PriorityEvaluator
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.rollout import run_episode
from training.research.labelling import Labeller

# -- the teacher and the features: the options that name them -----------------------------------

def lookahead_settings(candidates: int, futures: int | str):
    """``LookaheadSettings`` for ``--candidates`` and ``--futures`` (an int, or "expected"), as
    ``--evaluator lookahead:candidates=K+futures=F`` reads them."""

    return make_lookahead(f"candidates={candidates}+futures={futures}").settings


def futures_option(text: str) -> int | str:
    """``--futures``: "expected", or an int >= 0."""
    if text == "expected":
        return text
    if text.isdigit():
        return int(text)
    raise ValueError(f"--futures {text!r}: give an int >= 0 (0: the floor's own durations) or "
                     "expected (the expected paces)")


def teacher_options(text: str) -> str:
    """``--teacher``: the lookahead's options (``candidates=3+futures=16+race=4+floor=event+
    base=SPEC``; a leading ``lookahead:`` is allowed), checked by building the lookahead once
    (a bad option or a missing base file fails here, naming the fix)."""

    options = text.removeprefix("lookahead:")
    try:
        make_lookahead(options)
    except ValueError as err:
        raise ValueError(f"--teacher {text!r}: {err}") from None
    return options


def features_option(text: str) -> tuple[str, ...]:
    """``--features``: ``all`` (``ALL_FEATURES``), ``first`` (``FEATURE_NAMES``) or names from
    ``ALL_FEATURES`` joined by commas, each once."""

    if text in ("all", "first"):
        return ALL_FEATURES if text == "all" else FEATURE_NAMES
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in ALL_FEATURES]
    if unknown or not names or len(set(names)) != len(names):
        raise ValueError(f"--features {text!r}: give all, first, or names from "
                         f"{', '.join(ALL_FEATURES)} joined by commas, each once"
                         + (f" ({', '.join(unknown)} unknown)" if unknown else ""))
    return names


def label_teacher(args) -> str:
    """The teacher's lookahead options: ``--teacher``, or ``--candidates`` and ``--futures``
    (Eq. 9 as the base; their defaults 3 and 0), never both."""
    if args.teacher is not None:
        if args.candidates is not None or args.futures is not None:
            raise ValueError("--teacher names the whole lookahead; fix: put candidates=K and "
                             "futures=F inside it instead of --candidates and --futures")
        return teacher_options(args.teacher)
    candidates = 3 if args.candidates is None else args.candidates
    futures = futures_option("0" if args.futures is None else args.futures)
    lookahead_settings(candidates, futures)
    return f"candidates={candidates}+futures={futures}"


# -- labelling a floor --------------------------------------------------------------------------

def label_floor(case_path: str | None, seed: int, candidates: int = 3,
                futures: int | str = 0, acting: str | None = None, states: bool = False,
                teacher: str | None = None, features: tuple[str, ...] | None = None) -> dict:
    """One floor under the lookahead (or under ``acting``, the lookahead labelling): its
    makespan and the arrays of its decisions; with ``states``, each decision's floor too
    (``decision_state``). ``teacher``: the lookahead's options (``teacher_options``), instead
    of ``candidates`` and ``futures`` (a base rule of Eq. 9); ``features``: the candidate
    features kept (default ``FEATURE_NAMES``)."""

    features = tuple(features or FEATURE_NAMES)
    case = cmdp_pymunk.load_case(case_path)
    navigator = Navigator()  # drives the floor and, from its plans, the branches
    options = teacher if teacher is not None else f"candidates={candidates}+futures={futures}"
    spec = make_lookahead(options)
    lookahead = Labeller(LookaheadEvaluator(spec.base, spec.settings, low_level=navigator),
                         acting=evaluator_from_spec(acting) if acting else None)
    engine = Engine(case, evaluator=lookahead, park_idle=True)
    rows: list[tuple] = []
    priority = PriorityEvaluator()
    facts: list = []
    snapshots: list[bytes] = []

    def record(engine, i, values, decision) -> None:
        site = engine.site
        if not facts:
            facts.append(FloorFacts.of(site))
        crew = site.crews[i]
        priorities = priority.priorities(crew, site, engine.positions[i])
        phi = candidate_features(facts[0], crew, site, engine.positions[i],
                                 decision.candidates, priorities, engine.positions, features)
        rows.append((crew.type, [priorities[t] for t in decision.candidates], phi,
                     decision.makespans_s, decision.candidates.index(decision.choice)))
        if states:
            snapshots.append(decision_state(engine, navigator, i, decision.candidates))

    lookahead.on_decision = record
    start = time.perf_counter()
    run_episode(engine, navigator, seed, stall_s=3600.0, progress=False)
    return {"seed": seed, "makespan_s": engine.makespan_s, "rows": rows,
            "wall_s": time.perf_counter() - start,
            "overrides": lookahead.teacher.summary()["overrides"],
            "teacher": f"lookahead:{options}", "candidates": spec.settings.candidates,
            "features": features, "acting": acting or "", "states": snapshots}


def decision_state(engine, low_level, i: int, candidates: list[int]) -> bytes:
    """A decision's floor as a pickle: (engine, low level, crew i, candidates), the engine
    valuing by Eq. 9, its event log left out. What ``--states`` keeps, so that features the
    label files lack can be computed on the teacher's own states later
    (``label_noise.load_states``)
    without running the teacher again; a branch from it with the low level's copy is the
    teacher's own branch (the scripted navigator keeps state: a fresh one walks differently).
    A pickle of this code's classes: read it with the same commit."""


    # A clone rebuilds the original's world as the lookahead's own branches do at this
    # decision (a second rebuild from the same data changes nothing; tested).
    branch = engine.clone(engine.streams.scenario, keep_log=False)
    branch.evaluator = PriorityEvaluator()
    return pickle.dumps((branch, low_level, i, list(candidates)),
                        protocol=pickle.HIGHEST_PROTOCOL)


def save_labels(path: Path, result: dict, candidates: int | None = None) -> None:
    """A floor's labels as ``seed-N.npz`` (written whole, then moved into place: its presence
    marks the floor as done): per decision the crew type, the candidates' Eq. 9 values,
    features and makespans (NaN-padded to ``candidates``, default the teacher's), the
    teacher's choice; the feature names, the teacher and the acting policy."""

    rows = result["rows"]
    names = tuple(result.get("features") or FEATURE_NAMES)
    n, k = len(rows), candidates or result["candidates"]
    v = np.full((n, k), np.nan)
    phi = np.zeros((n, k, len(names)))
    makespan = np.full((n, k), np.nan)
    for r, (_, values, features, makespans, _) in enumerate(rows):
        m = len(values)
        v[r, :m], phi[r, :m], makespan[r, :m] = values, features, makespans
    if result.get("states"):


        # written before the label file, whose presence marks the floor as done
        write_atomic(path.with_name(path.name.replace(".npz", ".states.pkl")),
                     pickle.dumps(result["states"], protocol=pickle.HIGHEST_PROTOCOL))


    blob = io.BytesIO()
    np.savez_compressed(blob, crew_type=np.array([r[0] for r in rows], dtype="U8"), values=v,
                        features=phi, makespan_s=makespan,
                        choice=np.array([r[4] for r in rows], dtype=np.int64),
                        seed=result["seed"], floor_makespan_s=result["makespan_s"] or np.nan,
                        wall_s=result["wall_s"], teacher=result.get("teacher", ""),
                        acting=result.get("acting", ""),
                        feature_names=np.array(names, dtype="U32"))
    write_atomic(path, blob.getvalue())  # a stopped run leaves no half-written seed-N.npz


def _label_job(runner, case_path, seed, candidates, futures, acting=None, states=False,
               teacher=None, features=None):
    return label_floor(case_path, seed, candidates, futures, acting, states, teacher, features)


# -- reading label folders ----------------------------------------------------------------------

def label_files(folder: Path) -> list[Path]:
    """A label folder's ``seed-N.npz`` files, by seed."""
    files = [f for f in Path(folder).glob("seed-*.npz") if f.stem[5:].isdigit()]
    return sorted(files, key=lambda p: int(p.stem[5:]))


def load_labels(folders: Path | str | list) -> dict:
    """Every ``seed-N.npz`` of a label folder (or of several: one list of decisions, the
    folders in order) as one set of arrays, with ``feature_names``: the features' columns,
    which every file must share (a file written before they were stored holds
    ``FEATURE_NAMES``)."""

    folders = [folders] if isinstance(folders, (str, Path)) else list(folders)
    files = [f for folder in folders for f in label_files(folder)]
    if not files:
        raise ValueError(f"{', '.join(map(str, folders))}: no seed-N.npz label files; make "
                         f"them with `python -m training.research.distill label --out "
                         f"{folders[0]}`")
    parts = [np.load(f) for f in files]
    names = [tuple(str(n) for n in p["feature_names"]) if "feature_names" in p
             else FEATURE_NAMES for p in parts]
    if len(set(names)) > 1:
        odd = next(k for k, n in enumerate(names) if n != names[0])
        raise ValueError(f"label files with other features: {files[0]} has "
                         f"{', '.join(names[0])}; {files[odd]} has {', '.join(names[odd])}; "
                         "fix: fit on files of one --features (label the others again, or "
                         "move them to another folder)")
    return {"crew_type": np.concatenate([p["crew_type"] for p in parts]),
            "values": np.concatenate([p["values"] for p in parts]),
            "features": np.concatenate([p["features"] for p in parts]),
            "makespan_s": np.concatenate([p["makespan_s"] for p in parts]),
            "choice": np.concatenate([p["choice"] for p in parts]),
            "feature_names": names[0],
            "seeds": [int(p["seed"]) for p in parts],
            "row_seed": np.concatenate([np.full(len(p["choice"]), int(p["seed"]))
                                        for p in parts]),
            "teachers": [str(p["teacher"]) if "teacher" in p else "" for p in parts],
            "acting": [str(p["acting"]) if "acting" in p else "" for p in parts],
            "label_wall_s": [float(p["wall_s"]) for p in parts]}
