"""The low level and the target evaluator named on a command line.

``--evaluator priority|nearest|ga:PATH|cpsat|cpsat:PATH|MODEL.zip`` and
``--navigator scripted|MODEL.zip`` in ``cmdp-simulate`` and the other scripts; a model file
needs stable-baselines3 (imported only then).
"""

from __future__ import annotations

import difflib
from pathlib import Path

from cmdp_pymunk import evaluate
from cmdp_pymunk.policy import LowLevel

from .navigator import Navigator

EVALUATOR_HELP = ("priority (Eq. 9), nearest, uniform, ga:PATH (a task-priority file, e.g. made by "
                  "cmdp-ga), cpsat (replay a CP-SAT plan solved for the case), cpsat:PATH (a "
                  "saved plan), lookahead or lookahead:candidates=3+futures=1+base=priority "
                  "(branch the floor at each decision; futures=0 sees the true durations, "
                  "futures=expected the expected paces), "
                  "replan or replan:limit=1+overhead=150 (CP-SAT re-solves the rest of the "
                  "floor at each decision), "
                  "student:PATH (Eq. 9 plus a residual: fitted to the lookahead, or a "
                  "cmdp-search-rule rule.json), or a stage-2 model .zip (a desired position "
                  "or a masked choice)")


def evaluator_from_spec(spec: str):
    """The evaluator a command-line spec names (``--evaluator``, ``--strategies``; the core's own
    ``evaluate.make_evaluator`` takes names and objects): a name of the core's
    (``priority``, Eq. 9; ``nearest``; ...: ``evaluate.EVALUATORS``), ``ga:PATH`` or
    ``cpsat:PATH`` (a task-priority file), ``cpsat`` (a plan solved when bound to the env),
    or a stage-2 model ``.zip``; ValueError otherwise (naming the file and the fix)."""
    if spec in evaluate.EVALUATORS:
        return evaluate.make_evaluator(spec)
    if spec.startswith(("ga:", "cpsat:")):
        from .task_priority import load_priorities

        return load_priorities(spec.split(":", 1)[1])
    if spec == "cpsat":
        from .cpsat import PlanEvaluator

        return PlanEvaluator()
    if spec.startswith("student:"):
        from .student import StudentEvaluator

        return StudentEvaluator.load(spec.split(":", 1)[1])
    if spec == "lookahead" or spec.startswith("lookahead:"):
        return make_lookahead(spec.partition(":")[2])
    if spec == "replan" or spec.startswith("replan:"):
        return make_replan(spec.partition(":")[2])
    path = model_path(spec, "--evaluator")
    from .candidates import CandidateModelEvaluator, is_candidate_model

    if is_candidate_model(path):  # a masked choice (MaskablePPO), not a desired position
        return CandidateModelEvaluator(path)
    from .models import ModelEvaluator  # needs stable-baselines3

    return ModelEvaluator(path)


def _is_share(text: str) -> bool:
    try:
        return 0.0 <= float(text) < 1.0
    except ValueError:
        return False


def make_lookahead(options: str):
    """``lookahead:candidates=K+futures=F+race=R+base=SPEC+floor=event`` (each optional;
    ``+`` because ``--strategies`` separates strategies with commas) as an evaluator;
    ``floor=event`` branches on event floors built from the floor's state (think there, act on
    the floor); ``race=R`` sequential halving from H futures a candidate up to F;
    ``from=SHARE`` only once that share of the tasks has ended (the endgame)."""
    from .lookahead import LookaheadEvaluator, LookaheadSettings

    settings, base = {}, "priority"
    for item in filter(None, options.split("+")):
        key, sep, value = item.partition("=")
        if key == "base" and sep:
            base = value
        elif key == "futures" and value == "expected":
            settings["expected_paces"] = True
        elif key in ("candidates", "futures", "workers", "race") and sep and value.isdigit():
            settings[key] = int(value)
        elif key == "floor" and value in ("same", "event"):
            settings["think_on"] = value
        elif key == "from" and sep and _is_share(value):
            settings["from_share"] = float(value)
        else:
            raise ValueError(f"--evaluator lookahead:{options}: {item!r} is not one of "
                             f"candidates=INT, futures=INT or expected, workers=INT, "
                             f"race=INT, base=SPEC, floor=same or event, from=SHARE (of the "
                             f"tasks ended, in [0, 1)) (joined by +); e.g. "
                             f"lookahead:candidates=3+futures=1+base=priority")
    if base.startswith("lookahead"):
        raise ValueError("--evaluator lookahead: base=lookahead would branch inside branches; "
                         "give a rule such as base=priority or base=ga:PATH")
    return LookaheadEvaluator(evaluator_from_spec(base), LookaheadSettings(**settings))


def make_replan(options: str):
    """``replan:limit=S+overhead=S+window=S+base=SPEC`` (each optional) as an evaluator:
    CP-SAT re-solves the rest of the floor at each decision (``agents.replan``)."""
    from .replan import ReplanEvaluator, ReplanSettings

    settings, base = {}, "priority"
    for item in filter(None, options.split("+")):
        key, sep, value = item.partition("=")
        if key == "base" and sep:
            base = value
            continue
        if key in ("limit", "overhead", "window") and sep:
            try:
                settings[key if key == "limit" else key + "_s"] = float(value)
                continue
            except ValueError:
                pass
        raise ValueError(f"--evaluator replan:{options}: {item!r} is not one of "
                         f"limit=SECONDS, overhead=SECONDS, window=SECONDS, base=SPEC "
                         f"(joined by +); e.g. "
                         f"replan:limit=1+overhead=150+base=priority")
    if base.startswith(("lookahead", "replan")):
        raise ValueError(f"--evaluator replan: base={base} would plan inside plans; give a "
                         "rule such as base=priority or base=student:PATH")
    return ReplanEvaluator(evaluator_from_spec(base), ReplanSettings(**settings))


def make_navigator(spec: str, engine=None, deterministic: bool = False) -> LowLevel:
    """``scripted`` (the navigator) or a stage-1 reaching model ``.zip``, which samples its
    actions unless ``deterministic`` (argmax), bound to ``engine`` if given; ValueError for a
    missing file or a model that does not fit the engine's case."""
    if spec == "scripted":
        navigator = Navigator()
    else:
        from .models import PolicyNavigator

        navigator = PolicyNavigator(model_path(spec, "--navigator"), deterministic=deterministic)
    if engine is not None:
        navigator.bind(engine)
    return navigator


def model_path(spec: str, option: str) -> Path:
    """``spec`` as an existing file, or a ValueError naming ``option`` and the fix."""
    path = Path(spec)
    if not path.is_file():
        choices = ([*evaluate.EVALUATORS, "ga:PATH", "cpsat", "cpsat:PATH", "lookahead", "replan",
                    "student:PATH"] if option == "--evaluator" else ["scripted"])
        close = difflib.get_close_matches(spec, [c for c in choices if ":" not in c], n=1)
        hint = f"did you mean {close[0]!r}? " if close and not spec.endswith(".zip") else ""
        raise ValueError(f"{option} {spec!r}: no such model file; {hint}give a .zip saved by "
                         f"stable-baselines3, or one of {', '.join(choices)}")
    return path
