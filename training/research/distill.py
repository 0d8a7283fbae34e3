"""Distil the lookahead into a cheap evaluator: label decisions, then fit a residual over Eq. 9.

    python -m training.research.distill label --seeds 0-19 --out runs/labels [--futures
    0|N|expected]
                                     [--acting SPEC] [--workers 2] [--ray [ADDRESS]]
    python -m training.research.distill label --seeds 0-9 --out runs/labels-pi \
        --teacher candidates=3+futures=16+race=4+floor=event+base=student:PATH \
        --acting student:PATH [--features all|NAME,NAME,...]
    python -m training.research.distill fit runs/labels --out models/student_priority.json
                                     [--weights gap] [--features first|all|NAME,...]
    python -m training.research.distill fit-model runs/labels --out runs/distilled/model.zip
                                     [--typed] [--hold-choice]
    python -m training.research.distill student-model STUDENT.json --out MODEL.zip
                                     [--hold-choice] [--lift RULE.json]
    python -m training.research.distill noise runs/labels [--every 5] [--futures 2] [--workers 2]
    python -m training.research.distill relabel runs/labels --out runs/labels-all [--features all]

``label`` runs the lookahead (``agents.lookahead``) on each seed's floor and keeps, for every
decision with two or more candidates, the candidates' features (``agents.features``), their Eq.
9 values, the lookahead's makespan per candidate and its choice: one ``seed-N.npz`` per floor,
written whole as soon as its floor is done, so a stopped run resumes where it stopped (seeds
with a file are skipped). ``--teacher OPTIONS`` names the whole lookahead
(``agents.specs.make_lookahead``'s ``candidates=K+futures=F+race=R+floor=event+base=SPEC``)
instead of ``--candidates`` and ``--futures``; ``--features`` the candidate features kept (any
of ``agents.features.ALL_FEATURES``, their names stored in each file; files without names hold
``FEATURE_NAMES``). The floors run in worker processes, or on Ray actors with ``--ray``
(docs/ray.md). ``--futures expected`` labels with the certainty-equivalent lookahead (every
task not yet started at its expected pace: a choice that depends on the state alone, which a
student can learn). ``--acting SPEC`` is a DAgger round: the floor follows that evaluator (a
student, a rule, a masked-choice model) and the lookahead labels the decisions on its states.
``fit-model`` fits the masked-choice SB3 model (MaskablePPO, ``agents.candidates``) to the
labels by cross-entropy; ``--typed``, with typed rows (the crew's type as a one-hot) and a
per-type linear term (``Stage2Config.typed``), ``--hold-choice`` holding its choices as the
student does. ``student-model`` writes, without training, a typed masked-choice model whose
untrained policy is a per-type student (a student of ``FEATURE_NAMES``: ``fit --features
first``), for PPO to fine-tune (``start_model``); with ``--hold-choice`` it plays the student's
schedule; ``--lift RULE.json`` also gives it a lift head that starts as that learned logistics
rule (``logistics.Learned``, ``agents.lift``): the one model then answers the floor's lift
questions as the rule does. ``noise`` (``training.research.label_noise``) replays labelled
decisions kept with ``--states`` in other sampled futures: how much of a label is the future's
noise. ``relabel`` (``training.research.relabel``) computes other features for labels made with
``--acting`` by replaying their floors under the acting policy, without the teacher (a few
seconds a floor). ``fit`` fits the student (``agents.student``): per crew type a weight vector
w so that softmax(beta * (V' + w . phi)) over a decision's candidates matches the teacher's
soft choice (softmax of minus the makespans over ``tau_s``), with an L2 penalty; every weight 0
is Eq. 9 itself. ``--features`` fits on some of the labels' feature columns, taken by name
(policy iteration labels carry all 15; a typed model reads the 11 ``FEATURE_NAMES``).
``--weights gap`` weights each decision's cross-entropy by how much its choice matters
(``choice_weights``). The JSON it writes names the command, the label folder and the seeds.
Rounds of approximate policy iteration (label the student's own states, fit, make the student
the next base) are ``training.research.policy_iteration``.
"""

from __future__ import annotations

import io
import json
import pickle
import sys
import time
from pathlib import Path

import gymnasium
import numpy as np
import torch
from gymnasium import spaces
from scipy.optimize import minimize
from stable_baselines3.common.vec_env import DummyVecEnv
from tqdm import tqdm

import cmdp_pymunk
from agents.candidates import (
    CANDIDATE_COLUMNS,
    LIFT_ANSWERS,
    observation_bounds,
    type_columns,
)
from agents.features import ALL_FEATURES, FEATURE_NAMES, FloorFacts, candidate_features
from agents.lookahead import LookaheadEvaluator
from agents.navigator import Navigator
from agents.specs import evaluator_from_spec, make_lookahead
from agents.student import StudentEvaluator
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.evaluate import PriorityEvaluator
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.logistics import Learned
from cmdp_pymunk.rollout import run_episode
from training.cli import OneLineParser, add_ray_option, seed_list
from training.research.label_noise import noise
from training.research.labelling import Labeller
from training.research.relabel import _relabel_job, replace_option
from training.runs.backends import BackendError, open_backend
from training.stage2 import (
    DEFAULT_CONFIG,
    Stage2Config,
    crew_types,
    new_candidate_model,
    student_weights,
)

FIT_DEFAULTS = {"tau_s": 300.0, "l2": 1.0}


# -- labels -------------------------------------------------------------------------------------

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


def label(args) -> int:


    teacher = label_teacher(args)  # bad settings fail before any floor runs
    features = features_option(args.features)

    cmdp_pymunk.load_case(args.case)  # and so does a bad case file
    if args.acting:

        evaluator_from_spec(args.acting)  # so does a missing or unreadable acting policy
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    seeds = [s for s in seed_list(args.seeds) if not (out / f"seed-{s}.npz").exists()]
    print(f"label: {len(seed_list(args.seeds)) - len(seeds)} seeds already labelled in {out}; "
          f"{len(seeds)} to go (teacher lookahead:{teacher}, acting "
          f"{args.acting or 'the lookahead'}, {args.workers} worker(s))", flush=True)
    jobs = [(args.case, s, None, None, args.acting, args.states, teacher, features)
            for s in seeds]
    # Floors in worker processes, or on Ray actors (--ray): each file is written here as its
    # floor arrives, so a stopped run keeps every finished floor.
    with tqdm(total=len(jobs), unit="floor", desc="label", file=sys.stderr) as bar, \
            open_backend(_label_job, None, args.workers or None, args.ray) as pool:
        for _, result in pool.as_completed(jobs):
            _report(out, result, bar)
    return 0


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


def _report(out: Path, result: dict, bar) -> None:
    save_labels(out / f"seed-{result['seed']}.npz", result)
    bar.update(1)
    bar.write(f"label: seed {result['seed']}: makespan {result['makespan_s']} s, "
              f"{len(result['rows'])} decisions, {result['overrides']} overrides, "
              f"{result['wall_s']:.0f} s")


# -- fit ----------------------------------------------------------------------------------------

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


def soft_targets(makespan_s: np.ndarray, tau_s: float) -> np.ndarray:
    """The teacher's choice as probabilities: softmax(-(M - min M) / tau) over candidates
    (NaN-padded candidates get 0)."""
    m = np.where(np.isnan(makespan_s), np.inf, makespan_s)
    z = -(m - m.min(axis=1, keepdims=True)) / tau_s
    p = np.exp(z)
    return p / p.sum(axis=1, keepdims=True)


def choice_weights(makespan_s: np.ndarray) -> np.ndarray:
    """How much each decision's choice matters: the gap between its candidates' estimated
    makespans (max - min over the real, non-NaN candidates), divided by the mean gap of the
    rows given, so the weights average 1. A decision whose candidates all cost the same teaches
    nothing (weight 0: its soft target is flat, and fitting it only pulls the scores
    together); one where the wrong pick costs 800 s counts eight times one where it costs
    100 s. All gaps 0: all weights 0. Give it the rows of one crew type (``fit_weights``)."""
    gap = np.nanmax(makespan_s, axis=1) - np.nanmin(makespan_s, axis=1)
    mean = gap.mean() if len(gap) else 0.0
    return gap / mean if mean > 0 else np.zeros_like(gap)


FIT_WEIGHTS = ("none", "gap")  # fit_weights(weights=...): every decision alike, or by its gap


def fit_weights(data: dict, tau_s: float, l2: float,
                weights: str = "none") -> tuple[dict[str, np.ndarray], dict]:
    """Per crew type, w and beta minimising cross-entropy to the soft targets + l2 |w|^2;
    ``weights="gap"``: each decision's cross-entropy weighted by ``choice_weights`` (over the
    crew type's rows), so the fit spends itself where a choice costs seconds. L-BFGS from a
    fixed start: the same labels give the same weights."""

    if weights not in FIT_WEIGHTS:
        raise ValueError(f"fit weights {weights!r}: give one of {', '.join(FIT_WEIGHTS)}")
    out, report = {}, {}
    target = soft_targets(data["makespan_s"], tau_s)
    for crew_type in sorted(set(data["crew_type"])):
        rows = data["crew_type"] == crew_type
        v, phi, p = data["values"][rows], data["features"][rows], target[rows]
        mask = ~np.isnan(v)
        v0 = np.where(mask, v, 0.0)
        nf = phi.shape[2]
        row_weight = (choice_weights(data["makespan_s"][rows]) if weights == "gap"
                      else np.ones(len(v0)))

        def loss(x, v0=v0, phi=phi, p=p, mask=mask, row_weight=row_weight):
            beta, w = np.exp(x[0]), x[1:]
            logits = np.where(mask, beta * (v0 + phi @ w), -np.inf)
            top = logits.max(axis=1, keepdims=True)
            logp = logits - top - np.log(np.exp(logits - top).sum(axis=1, keepdims=True))
            per_row = -np.sum(p * np.where(mask, logp, 0.0), axis=1)  # padded: p = 0
            return float(row_weight @ per_row) / len(v0) + l2 * float(w @ w) / len(v0)

        x0 = np.zeros(1 + nf)
        x0[0] = np.log(5.0)  # beta: V' differences of about 0.2 give odds of about e
        res = minimize(loss, x0, method="L-BFGS-B")
        w = res.x[1:]
        base_choice = np.argmax(np.where(mask, v0, -np.inf), axis=1)
        student_choice = np.argmax(np.where(mask, v0 + phi @ w, -np.inf), axis=1)
        teacher = np.argmax(p, axis=1)
        out[str(crew_type)] = w
        report[str(crew_type)] = {
            "decisions": int(rows.sum()), "beta": round(float(np.exp(res.x[0])), 3),
            "agree_base_teacher": round(float(np.mean(base_choice == teacher)), 3),
            "agree_student_teacher": round(float(np.mean(student_choice == teacher)), 3),
            "loss_zero_weights": round(float(loss(np.r_[res.x[0], np.zeros(nf)])), 4),
            "loss": round(float(res.fun), 4)}
    return out, report


def select_features(data: dict, names: tuple[str, ...] | None) -> dict:
    """The labels with only the feature columns ``names`` (taken by name, in that order;
    None: all of them); ValueError naming the missing ones and the fix."""
    if names is None:
        return data
    have = tuple(data["feature_names"])
    missing = [n for n in names if n not in have]
    if missing:
        raise ValueError(f"--features {','.join(names)}: the labels hold {', '.join(have)} "
                         f"({', '.join(missing)} missing); fix: choose from those, or label "
                         "with --features all")
    return {**data, "features": data["features"][..., [have.index(n) for n in names]],
            "feature_names": tuple(names)}


def fit(args) -> int:

    data = load_labels([Path(f) for f in args.labels])
    data = select_features(data, features_option(args.features) if args.features else None)
    weights, report = fit_weights(data, args.tau_s, args.l2, args.weights)
    student = StudentEvaluator({k: v.tolist() for k, v in weights.items()},
                               candidates=data["values"].shape[1],
                               features=data["feature_names"])
    meta = {"command": "python -m training.research.distill " + " ".join(args.argv),
            "labels": [str(f) for f in args.labels], "label_seeds": data["seeds"],
            "label_wall_s_per_floor": round(float(np.mean(data["label_wall_s"])), 1),
            "tau_s": args.tau_s, "l2": args.l2, "fit_weighting": args.weights, "fit": report}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    student.save(Path(args.out), meta)
    for crew_type, r in report.items():
        print(f"fit: {crew_type}: {r['decisions']} decisions, teacher agrees with Eq. 9 on "
              f"{r['agree_base_teacher']:.0%}, with the student on "
              f"{r['agree_student_teacher']:.0%} (loss {r['loss_zero_weights']} -> {r['loss']})")
    print(f"fit: wrote {args.out}")
    return 0


# -- fit-model: the masked-choice SB3 model by cross-entropy ------------------------------------

MODEL_FIT_DEFAULTS = {"tau_s": 300.0, "epochs": 1000, "patience": 30, "lr": 3e-3,
                      "weight_decay": 1e-4, "validation": 0.2}
MODEL_FIT_HELP = {"tau_s": "temperature of the teacher's soft choice, in seconds of makespan",
                  "epochs": "full-batch Adam steps at most",
                  "patience": "stop after this many steps without a lower validation loss",
                  "lr": "Adam's learning rate", "weight_decay": "Adam's weight decay",
                  "validation": "share of the label floors (the highest seeds) held back"}


def choice_rows(data: dict, cap: int, types: tuple[str, ...] = ()) \
        -> tuple[np.ndarray, np.ndarray]:
    """The labels as the masked-choice policy sees its decisions (``agents.candidates``): one
    flat row block per decision (V' then the features, clipped to the observation's bounds,
    padded with zeros) and the mask of real candidates. ``types``: typed rows, each ending in
    the one-hot of the decision's ``crew_type`` over this vocabulary (``CREW_TYPES``; a type
    outside it: zeros)."""

    values, features = data["values"], data["features"]
    names = tuple(data.get("feature_names", CANDIDATE_COLUMNS[1:]))
    missing = [c for c in CANDIDATE_COLUMNS[1:] if c not in names]
    if missing:
        raise ValueError(f"labels with features {', '.join(names)}: the masked-choice model "
                         f"reads {', '.join(CANDIDATE_COLUMNS[1:])} ({', '.join(missing)} "
                         "missing); fix: label with --features first or all")
    if types and "crew_type" not in data:
        raise ValueError("typed rows need the labels' crew_type; fix: label again with "
                         "`python -m training.research.distill label` (its files carry it)")
    # labels with more features (policy iteration labels all of ALL_FEATURES): the model's
    # columns, taken by name
    features = features[..., [names.index(c) for c in CANDIDATE_COLUMNS[1:]]]
    n, k = values.shape
    if k > cap:
        raise ValueError(f"labels of {k} candidates for a policy of {cap}; fix: --candidates {k}")
    width, plain = len(CANDIDATE_COLUMNS) + len(types), len(CANDIDATE_COLUMNS)
    table = np.zeros((n, cap, width), np.float32)
    mask = np.zeros((n, cap), bool)
    mask[:, :k] = ~np.isnan(values)
    table[:, :k, 0] = np.where(mask[:, :k], values, 0.0)
    table[:, :k, 1:plain] = np.where(mask[:, :k, None], features, 0.0)
    if types:
        onehot = np.stack([type_columns(str(t), tuple(types)) for t in data["crew_type"]])
        table[:, :, plain:] = onehot[:, None, :]
    low, high = observation_bounds(cap, len(types))
    flat = np.clip(table.reshape(n, -1), low, high)
    return flat * np.repeat(mask, width, axis=1), mask


def choice_venv(cap: int, types: int = 0, lift: int = 0):
    """A vector env with only the spaces of a masked-choice floor (``training.candidate_loop``;
    ``types``: that many crew-type columns a row; ``lift``: that many lift features in a lift
    block, and the two lift answers, ``agents.candidates``): enough to build the model
    without running floors."""


    low, high = observation_bounds(cap, types, lift)
    actions = cap + (LIFT_ANSWERS if lift else 0)

    class ChoiceSpaces(gymnasium.Env):
        observation_space = spaces.Box(low, high, dtype=np.float32)
        action_space = spaces.Discrete(actions)

        def reset(self, *, seed=None, options=None):
            return self.observation_space.low.copy(), {}

        def step(self, action):
            raise RuntimeError("fit-model builds the model; it plays no floor")

        def action_masks(self):
            return np.ones(actions, bool)

    return DummyVecEnv([ChoiceSpaces])


def new_choice_model(cap: int, start_rule: str, seed: int, typed: bool = False,
                     hold_choice: bool = False, lift: Learned | None = None):
    """A fresh masked-choice MaskablePPO (``training.stage2``'s, from
    ``training/configs/stage2_candidate.toml``) that starts as Eq. 9 or as ``start_rule``
    (typed: a per-type student, ``Stage2Config.typed``); ``hold_choice`` is saved with it.
    ``lift``: a learned logistics rule (``logistics.Learned``) the model's lift head starts
    as (its features, shares and weights; ``CandidateScorer.start_from_lift``)."""

    settings = Stage2Config.load(DEFAULT_CONFIG.with_name("stage2_candidate.toml")).model_dump()
    config = Stage2Config.model_validate({**settings, "candidates": cap,
                                          "start_rule": start_rule, "seed": seed,
                                          "typed": typed, "hold_choice": hold_choice})
    types = len(crew_types(config))
    if lift is None:
        return new_candidate_model(config, choice_venv(cap, types))
    head = {"lift_features": lift.features, "lift_shares": lift.shares}
    model = new_candidate_model(config, choice_venv(cap, types, len(lift.features)), head)
    model.policy.action_net.start_from_lift(lift.weights, lift.bias)
    return model


def choice_agreement(logits: np.ndarray, mask: np.ndarray, target: np.ndarray) -> float:
    """Share of decisions whose argmax (over real candidates) is the teacher's choice."""
    pick = np.argmax(np.where(mask, logits, -np.inf), axis=1)
    return float(np.mean(pick == np.argmax(target, axis=1)))


def choice_regret_s(scores: np.ndarray, mask: np.ndarray, makespan_s: np.ndarray) -> float:
    """Mean seconds of the teacher's makespan lost by taking the argmax of ``scores`` instead
    of the teacher's best candidate (0 for the teacher itself)."""
    k = makespan_s.shape[1]
    pick = np.argmax(np.where(mask, scores, -np.inf)[:, :k], axis=1)
    m = np.where(np.isnan(makespan_s), np.inf, makespan_s)
    return float(np.mean(m[np.arange(len(m)), pick] - m.min(axis=1)))


def fit_choice_model(data: dict, cap: int, start_rule: str = "", seed: int = 0,
                     settings: dict | None = None, log=print, typed: bool = False,
                     hold_choice: bool = False):
    """Fit the masked-choice policy's scorer to the teacher's soft choices by cross-entropy
    (Adam, early stopping on the label floors held back for validation: the last
    ``validation`` share of the seeds); returns the model and a report. ``typed``: typed
    rows from the labels' ``crew_type`` and a per-type term (``Stage2Config.typed``);
    ``hold_choice``: saved with the model."""

    settings = {**MODEL_FIT_DEFAULTS, **(settings or {})}
    torch.manual_seed(seed)
    model = new_choice_model(cap, start_rule, seed, typed, hold_choice)
    scorer = model.policy.action_net
    flat, mask = choice_rows(data, cap, model.policy.types)
    target = np.zeros(mask.shape)
    target[:, :data["values"].shape[1]] = soft_targets(data["makespan_s"], settings["tau_s"])
    seeds = np.asarray(data["row_seed"])
    floors = sorted(int(s) for s in set(seeds))
    held = floors[-max(1, round(settings["validation"] * len(floors))):]
    val = np.isin(seeds, held)
    if val.all():
        raise ValueError("fit-model needs labels of at least 2 seeds (one is held for "
                         "validation)")
    x, m, p = (torch.as_tensor(a) for a in (flat, mask, target.astype(np.float32)))

    def loss_and_logits(rows):
        logits = scorer(x[rows]).masked_fill(~m[rows], -1e9)
        logp = torch.log_softmax(logits, dim=1)
        return -(p[rows] * logp.masked_fill(~m[rows], 0.0)).sum(1).mean(), logits

    train_rows, val_rows = torch.as_tensor(~val), torch.as_tensor(val)
    with torch.no_grad():
        start_val = loss_and_logits(val_rows)[0]
        start_logits = scorer(x).masked_fill(~m, -1e9).numpy()
    optimizer = torch.optim.Adam(scorer.parameters(), lr=settings["lr"],
                                 weight_decay=settings["weight_decay"])
    best = (float(start_val), 0, {k: v.clone() for k, v in scorer.state_dict().items()})
    epoch = 0
    for epoch in range(1, settings["epochs"] + 1):
        optimizer.zero_grad()
        loss, _ = loss_and_logits(train_rows)
        loss.backward()
        optimizer.step()
        with torch.no_grad():
            val_loss = float(loss_and_logits(val_rows)[0])
        if val_loss < best[0] - 1e-5:
            best = (val_loss, epoch, {k: v.clone() for k, v in scorer.state_dict().items()})
        elif epoch - best[1] >= settings["patience"]:
            break
    scorer.load_state_dict(best[2])
    with torch.no_grad():
        logits = scorer(x).masked_fill(~m, -1e9).numpy()
        eq9 = np.where(mask, flat.reshape(len(flat), cap, -1)[:, :, 0], -np.inf)
    report = {"decisions": int(len(flat)), "validation_seeds": [int(s) for s in held],
              "epochs_run": epoch, "best_epoch": best[1],
              "validation_loss_start": round(float(start_val), 4),
              "validation_loss": round(best[0], 4)}
    for name, rows in (("train", ~val), ("validation", val)):
        for who, scores in (("eq9", eq9), ("start", start_logits), ("model", logits)):
            report[f"agree_{who}_teacher_{name}"] = round(
                choice_agreement(scores[rows], mask[rows], target[rows]), 3)
            report[f"regret_{who}_{name}_s"] = round(
                choice_regret_s(scores[rows], mask[rows], data["makespan_s"][rows]), 1)
    log(f"fit-model: {report['decisions']} decisions, best epoch {best[1]} of {epoch}; "
        f"validation seeds {held}: teacher agrees with Eq. 9 on "
        f"{report['agree_eq9_teacher_validation']:.0%}, with the start on "
        f"{report['agree_start_teacher_validation']:.0%}, with the model on "
        f"{report['agree_model_teacher_validation']:.0%} (loss "
        f"{report['validation_loss_start']} -> {report['validation_loss']}); the teacher's "
        f"makespan lost a decision: Eq. 9 {report['regret_eq9_validation_s']:.0f} s, start "
        f"{report['regret_start_validation_s']:.0f} s, model "
        f"{report['regret_model_validation_s']:.0f} s")
    return model, report


def fit_model(args) -> int:
    data = load_labels([Path(f) for f in args.labels])
    cap = args.candidates or data["values"].shape[1]
    if args.start_rule and not args.candidates:

        # the rule's own candidate count (labels of fewer leave the other rows masked)
        cap = max(cap, StudentEvaluator.load(args.start_rule).candidates)
    settings = {k: getattr(args, k) for k in MODEL_FIT_DEFAULTS}
    model, report = fit_choice_model(data, cap, args.start_rule or "", args.seed, settings,
                                     typed=args.typed, hold_choice=args.hold_choice)
    meta = {"command": "python -m training.research.distill " + " ".join(args.argv),
            "labels": [str(f) for f in args.labels], "label_seeds": data["seeds"],
            "teachers": sorted(set(data["teachers"])), "acting": sorted(set(data["acting"])),
            "label_wall_s_per_floor": round(float(np.mean(data["label_wall_s"])), 1),
            "candidates": cap, "start_rule": args.start_rule or "", "seed": args.seed,
            "typed": args.typed, "hold_choice": args.hold_choice,
            "settings": settings, "fit": report}
    save_model(model, Path(args.out), meta, "fit-model")
    return 0


def save_model(model, out: Path, meta: dict, command: str) -> None:
    """The model zip and ``NAME.distill.json`` (``meta``) beside it, each written whole and
    moved into place (the zip last, so a zip always has its json)."""


    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.stem + ".tmp.zip")
    model.save(tmp)
    write_atomic(out.with_suffix(".distill.json"), json.dumps(meta, indent=1) + "\n")
    tmp.replace(out)
    print(f"{command}: wrote {out} (use it as --evaluator {out}) and "
          f"{out.with_suffix('.distill.json')}")


# -- student-model: a typed masked-choice model that starts as a student --------------------------

def student_model(args) -> int:
    """A typed MaskablePPO masked-choice model whose untrained policy is the student of
    ``args.student`` (``agents.student``; no training): the default stage-2 candidate config
    with the student's ``candidates``, the per-type weights in the policy's per-type term
    (``CandidateScorer.start_from_student``), ``--hold-choice`` saved with it."""


    cap = StudentEvaluator.load(args.student).candidates  # a bad file fails here, named
    student = student_weights(args.student, cap, "student-model")  # and other features here
    try:  # and a bad lift rule here, before anything is built
        lift = Learned(args.lift) if args.lift else None
    except (OSError, ValueError) as err:
        raise ValueError(f"--lift {args.lift}: {err}") from None
    data = json.loads(Path(args.student).read_text(encoding="utf-8"))
    model = new_choice_model(cap, str(args.student), args.seed, typed=True,
                             hold_choice=args.hold_choice, lift=lift)
    meta = {"command": "python -m training.research.distill " + " ".join(args.argv),
            "student": str(args.student), "candidates": cap, "typed": True,
            "hold_choice": args.hold_choice, "seed": args.seed,
            "crew_types": sorted(student),
            "student_meta": {k: v for k, v in data.items() if k != "weights"}}
    if lift is not None:  # the lift head's start, and the rule's own provenance
        meta["lift"] = {"rule": str(args.lift), "features": list(lift.features),
                        "weights": list(lift.weights), "bias": lift.bias,
                        "shares": list(lift.shares),
                        "rule_command": lift.meta.get("command", "")}
    save_model(model, Path(args.out), meta, "student-model")
    return 0


# -- relabel ------------------------------------------------------------------------------------

def relabel(args) -> int:
    """``relabel`` (``training.research.relabel``): the label folders' floors replayed, with
    other features, into ``--out`` (resumes; each file written whole)."""



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
    with tqdm(total=len(jobs), unit="floor", desc="relabel", file=sys.stderr) as bar, \
            open_backend(_relabel_job, None, args.workers or None) as pool:
        for _, result in pool.as_completed(jobs):
            blob = io.BytesIO()
            np.savez_compressed(blob, **result["arrays"])
            write_atomic(out / Path(result["path"]).name, blob.getvalue())
            bar.update(1)
    return 0


def add_relabel_parser(sub) -> None:
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


def main(argv: list[str] | None = None) -> int:

    argv = list(sys.argv[1:] if argv is None else argv)
    parser = OneLineParser(prog="python -m training.research.distill",
                           description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("label", help="label decisions with the lookahead, one file per seed")
    p.add_argument("--case", default=None, help="case file (default: built-in)")
    p.add_argument("--seeds", default="0-19", help="training seeds, e.g. 0-19")
    p.add_argument("--candidates", type=int, default=None,
                   help="top-k of Eq. 9 tried (default 3)")
    p.add_argument("--futures", default=None,
                   help="sampled futures per candidate (0, the default: the floor's own "
                        "durations), or expected (one branch at the expected paces)")
    p.add_argument("--teacher", default=None, metavar="OPTIONS",
                   help="the whole lookahead instead of --candidates and --futures, e.g. "
                        "candidates=3+futures=16+race=4+floor=event+base=student:PATH "
                        "(agents.specs.make_lookahead's options)")
    p.add_argument("--features", default="first",
                   help="candidate features kept: first (the 11 FEATURE_NAMES, default), all "
                        "(ALL_FEATURES, with the binding ones) or names joined by commas")
    p.add_argument("--acting", default=None, metavar="SPEC",
                   help="DAgger: the floor follows this evaluator (e.g. student:PATH or a "
                        "masked-choice model .zip) and the lookahead only labels")
    p.add_argument("--workers", type=int, default=1,
                   help="worker processes, or Ray actors with --ray (0 with --ray ADDRESS: one "
                        "per CPU of the cluster)")
    p.add_argument("--states", action="store_true",
                   help="also keep each decision's floor (seed-N.states.pkl, pickled; about "
                        "70 KB a decision on the built-in case) to compute new features on "
                        "the teacher's states later without running it again (read with the "
                        "same commit)")
    add_ray_option(p)
    p.add_argument("--out", default="runs/labels", help="label folder (resumes)")
    f = sub.add_parser("fit", help="fit the student to a label folder")
    f.add_argument("labels", nargs="+", help="label folder(s) made by `label` (several: "
                   "their decisions together, e.g. the rounds of policy iteration)")
    f.add_argument("--out", default="models/student_priority.json")
    f.add_argument("--tau-s", type=float, default=FIT_DEFAULTS["tau_s"],
                   help="temperature of the teacher's soft choice, in seconds of makespan")
    f.add_argument("--l2", type=float, default=FIT_DEFAULTS["l2"], help="weight penalty")
    f.add_argument("--weights", choices=FIT_WEIGHTS, default="none",
                   help="gap: weight each decision by the gap between its candidates' "
                        "makespans (how much the choice matters); none: all alike (default)")
    f.add_argument("--features", default=None,
                   help="fit on these of the labels' features, taken by name: first (the 11 "
                        "FEATURE_NAMES a typed model reads: student-model), all "
                        "(ALL_FEATURES) or names joined by commas (default: all the labels "
                        "hold)")
    m = sub.add_parser("fit-model", help="fit the masked-choice SB3 model (MaskablePPO) to a "
                       "label folder by cross-entropy")
    m.add_argument("labels", nargs="+", help="label folder(s) made by `label`")
    m.add_argument("--out", default="runs/distilled/model.zip", help="model zip to write "
                   "(and NAME.distill.json beside it: the command, the labels, the fit)")
    m.add_argument("--candidates", type=int, default=0,
                   help="the policy's candidate cap (default: the labels')")
    m.add_argument("--start-rule", default="",
                   help="start from this searched rule (cmdp-search-rule's rule.json) "
                        "instead of Eq. 9")
    m.add_argument("--typed", action="store_true",
                   help="typed rows (a one-hot of the crew's type) and a per-type linear term; "
                        "--start-rule may then be a per-type student")
    m.add_argument("--hold-choice", action="store_true",
                   help="the model holds a choice until the crew reaches a target, as the "
                        "student does")
    m.add_argument("--seed", type=int, default=0, help="torch seed")
    for key, value in MODEL_FIT_DEFAULTS.items():
        m.add_argument(f"--{key.replace('_', '-')}", type=type(value), default=value,
                       help=f"{MODEL_FIT_HELP[key]} (default {value})")
    s = sub.add_parser("student-model", help="write a typed masked-choice model (MaskablePPO) "
                       "that starts as a per-type student, without training")
    s.add_argument("student", help="student JSON of `fit --features first`")
    s.add_argument("--out", required=True, help="model zip to write (and NAME.distill.json "
                   "beside it: the command, the student and its meta)")
    s.add_argument("--hold-choice", action="store_true",
                   help="hold a choice until the crew reaches a target, as the student does "
                        "(then it plays the student's schedule)")
    s.add_argument("--seed", type=int, default=0, help="torch seed (the critic's start)")
    s.add_argument("--lift", default="", metavar="RULE.json",
                   help="also give the model a lift head that starts as this learned logistics "
                        "rule (logistics.Learned, e.g. models/logistics_learned.json): the one "
                        "model then answers the floor's lift questions too")
    n = sub.add_parser("noise", help="how much of the teacher's labels holds in other "
                       "futures (needs label --states; training/research/label_noise.py)")
    n.add_argument("labels", help="label folder made by `label --states`")
    n.add_argument("--every", type=int, default=5, help="replay every N-th decision")
    n.add_argument("--futures", type=int, default=2,
                   help="sampled futures per decision, shared by its candidates")
    n.add_argument("--workers", type=int, default=1, help="worker processes")
    n.add_argument("--out", default="", help="also write the report (JSON) here")
    add_relabel_parser(sub)
    args = parser.parse_args(argv)
    args.argv = argv

    commands = {"label": label, "fit": fit, "fit-model": fit_model,
                "student-model": student_model, "noise": noise,
                "relabel": relabel}
    try:
        return commands[args.command](args)
    except (ValueError, BackendError) as err:
        print(f"distill: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        kept = {"label": "finished seeds are kept (run again to resume)",
                "relabel": "finished floors are kept (run again to resume)"}
        print(f"\ndistill: interrupted; {kept.get(args.command, 'no output is half-written')}",
              file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
