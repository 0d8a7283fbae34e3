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

This module is the command line: each subcommand's entry function beside its parser, and
``main``. What they run is apart (issue 43: modules a reader holds at once): ``distill_labels``
(the teacher's options, labelling a floor, label files), ``distill_fit`` (the student's fit),
``distill_model`` (the masked-choice model's fit, SB3); importable from here too (``__all__``).
"""

from __future__ import annotations

import io
import json
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

import cmdp_pymunk
from agents.specs import evaluator_from_spec
from agents.student import StudentEvaluator
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.logistics import Learned
from training.cli import OneLineParser, add_ray_option, seed_list
from training.research.distill_fit import (
    FIT_DEFAULTS,
    FIT_WEIGHTS,
    choice_weights,
    fit_weights,
    select_features,
    soft_targets,
)
from training.research.distill_labels import (
    _label_job,
    decision_state,
    features_option,
    futures_option,
    label_files,
    label_floor,
    label_teacher,
    load_labels,
    lookahead_settings,
    save_labels,
    teacher_options,
)
from training.research.distill_model import (
    MODEL_FIT_DEFAULTS,
    MODEL_FIT_HELP,
    choice_agreement,
    choice_regret_s,
    choice_rows,
    choice_venv,
    fit_choice_model,
    new_choice_model,
    save_model,
)
from training.research.label_noise import noise
from training.research.relabel import _relabel_job, replace_option
from training.runs.backends import BackendError, open_backend
from training.stage2 import student_weights

__all__ = [
    "main", "label", "fit", "fit_model", "student_model", "relabel",
    "add_label_parser", "add_fit_parser", "add_fit_model_parser", "add_student_model_parser",
    "add_noise_parser", "add_relabel_parser", "build_parser",
    # re-exported: they lived here before the split, and docs, the changelog and older
    # scripts name them ``training.research.distill.X``
    "lookahead_settings", "futures_option", "teacher_options", "features_option", "label_teacher",
    "label_floor", "decision_state", "save_labels", "label_files", "load_labels",
    "FIT_DEFAULTS", "soft_targets", "choice_weights", "FIT_WEIGHTS", "fit_weights",
    "select_features",
    "MODEL_FIT_DEFAULTS", "MODEL_FIT_HELP", "choice_rows", "choice_venv", "new_choice_model",
    "choice_agreement", "choice_regret_s", "fit_choice_model", "save_model",
]


# -- label ----------------------------------------------------------------------------------------

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


def _report(out: Path, result: dict, bar) -> None:
    save_labels(out / f"seed-{result['seed']}.npz", result)
    bar.update(1)
    bar.write(f"label: seed {result['seed']}: makespan {result['makespan_s']} s, "
              f"{len(result['rows'])} decisions, {result['overrides']} overrides, "
              f"{result['wall_s']:.0f} s")


def add_label_parser(sub) -> None:
    """``label``'s arguments."""
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


# -- fit ------------------------------------------------------------------------------------------

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


def add_fit_parser(sub) -> None:
    """``fit``'s arguments."""
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


# -- fit-model: the masked-choice SB3 model by cross-entropy --------------------------------------

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


def add_fit_model_parser(sub) -> None:
    """``fit-model``'s arguments (the fit's settings from ``MODEL_FIT_DEFAULTS``)."""
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


def add_student_model_parser(sub) -> None:
    """``student-model``'s arguments."""
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


# -- noise (training.research.label_noise) --------------------------------------------------------

def add_noise_parser(sub) -> None:
    """``noise``'s arguments (``training.research.label_noise``)."""
    n = sub.add_parser("noise", help="how much of the teacher's labels holds in other "
                       "futures (needs label --states; training/research/label_noise.py)")
    n.add_argument("labels", help="label folder made by `label --states`")
    n.add_argument("--every", type=int, default=5, help="replay every N-th decision")
    n.add_argument("--futures", type=int, default=2,
                   help="sampled futures per decision, shared by its candidates")
    n.add_argument("--workers", type=int, default=1, help="worker processes")
    n.add_argument("--out", default="", help="also write the report (JSON) here")


# -- relabel --------------------------------------------------------------------------------------

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
    """``relabel``'s arguments (``training.research.relabel``)."""
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


# -- the command line -----------------------------------------------------------------------------

def build_parser() -> OneLineParser:
    """Every subcommand's parser, in the order ``--help`` lists them."""
    parser = OneLineParser(prog="python -m training.research.distill",
                           description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for add in (add_label_parser, add_fit_parser, add_fit_model_parser,
                add_student_model_parser, add_noise_parser, add_relabel_parser):
        add(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """``python -m training.research.distill``: parse, run the subcommand; 2 on bad input
    (named), 130 when interrupted."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
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
