"""The low level and the target evaluator named on a command line.

``--evaluator priority|nearest|MODEL.zip`` and ``--navigator scripted|MODEL.zip`` in
``cmdp-simulate`` and the other scripts; a model file needs stable-baselines3 (imported only
then).
"""

from __future__ import annotations

from pathlib import Path

from cmdp_pymunk.evaluate import NearestFirstEvaluator
from cmdp_pymunk.policy import LowLevel

from .navigator import Navigator
from .priority import PriorityEvaluator


def make_evaluator(spec: str):
    """``priority`` (Eq. 9), ``nearest`` or a stage-2 model ``.zip``; ValueError otherwise."""
    if spec == "priority":
        return PriorityEvaluator()
    if spec == "nearest":
        return NearestFirstEvaluator()
    from .models import ModelEvaluator  # needs stable-baselines3

    return ModelEvaluator(model_path(spec, "--evaluator"))


def make_navigator(spec: str, env, deterministic: bool = False) -> LowLevel:
    """``scripted`` (the navigator) or a stage-1 reaching model ``.zip``, which samples its
    actions unless ``deterministic`` (argmax), bound to ``env``; ValueError for a missing file
    or a model that does not fit the env's observation."""
    if spec == "scripted":
        navigator = Navigator()
    else:
        from .models import PolicyNavigator

        navigator = PolicyNavigator(model_path(spec, "--navigator"), deterministic=deterministic)
    navigator.bind(env)
    return navigator


def model_path(spec: str, option: str) -> Path:
    """``spec`` as an existing file, or a ValueError naming ``option`` and the fix."""
    path = Path(spec)
    if not path.is_file():
        raise ValueError(f"{option} {spec!r}: no such model file; give a .zip saved by "
                         "stable-baselines3, or one of the built-in names")
    return path
