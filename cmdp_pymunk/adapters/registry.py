"""The env's variants in PettingZoo's registry (PettingZoo 1.27: ``pettingzoo.register`` /
``pettingzoo.make``), registered when ``cmdp_pymunk`` is imported::

    import cmdp_pymunk, pettingzoo
    env = pettingzoo.make("parallel", "cmdp/PrecastFloor-v1")     # ParallelEnv
    env = pettingzoo.make("aec", "cmdp/PrecastFloor-stage1-v1")   # AEC, via parallel_to_aec

``cmdp/PrecastFloor-v1`` (the paper's floor, full CMDP), ``cmdp/PrecastFloor-stage1-v1``
(section 4.2's stage 1 on it), ``cmdp/PrecastFloor-disrupted-v1`` (the paper's floor with the
disruption profile of docs/disruptions.md), ``cmdp/PrecastFloor-reorder-v1`` (the paper's floor
with reorder points for its materials, beyond the paper), ``cmdp/TinyFloor-v1`` (the tiny case
of the docs and tests),
and the generated layouts' split ``cmdp/GeneratedFloor-train0-v1`` ... and
``cmdp/GeneratedFloor-test0-v1`` ... (``cmdp_pymunk.cases.generated``).

Every variant takes the env's arguments as keyword overrides (``seed``, ``render_mode``,
``max_time_s``, ...). Targets are valued by the priority heuristic (Eq. 9), the env's default,
unless ``evaluator`` says otherwise: a name of ``evaluate.EVALUATORS`` (``"nearest"``, ...)
or an evaluator object.
The version (``-v1``) follows the env's (``CMDPEnv.metadata["name"]``).

The stage-2 decision env (``decision_loop.TargetEvaluationEnv``: one step is one target
evaluation) is a single-agent Gymnasium env, in Gymnasium's registry::

    import cmdp_pymunk, gymnasium
    env = gymnasium.make("cmdp/TargetEvaluation-v1")         # the pymunk floor, the navigator
    env = gymnasium.make("cmdp/TargetEvaluationEvent-v1")    # the event floor: fast, same spaces

``DECISION_VARIANTS``; each takes ``decision_loop.make_decision_env``'s arguments as keyword
overrides (``case``, ``max_time_s``, ``with_state``, ``calibration``, ...).
"""

from __future__ import annotations

import gymnasium
from pettingzoo import register
from pettingzoo.utils.conversions import parallel_to_aec

from ..cases.generated import layout_files
from ..cases.load import DISRUPTED_CASE, REORDER_CASE, TINY_CASE
from .env import CMDPEnv

STAGE1_EPISODE_S = 3000.0  # stage-1 episodes are cut here, as in training/configs/stage1.toml

# id -> default keyword arguments of CMDPEnv (case None: the built-in case, the paper's)
VARIANTS: dict[str, dict] = {
    "cmdp/PrecastFloor-v1": {"stage": 2},
    "cmdp/PrecastFloor-stage1-v1": {"stage": 1, "max_time_s": STAGE1_EPISODE_S},
    # the tiny case of the docs and the tests: 2 crews, 3 tasks, episodes of seconds
    "cmdp/TinyFloor-v1": {"stage": 2, "case": str(TINY_CASE)},
    # the paper's floor with crane breakdowns, late deliveries, absences and weather stops
    # (the profile of docs/disruptions.md, cases/precast_floor_disrupted.toml)
    "cmdp/PrecastFloor-disrupted-v1": {"stage": 2, "case": str(DISRUPTED_CASE)},
    # the paper's floor with a reorder point at half a lift for every material (beyond the
    # paper: a lift asked for before the storage runs dry; cases/precast_floor_reorder.toml)
    "cmdp/PrecastFloor-reorder-v1": {"stage": 2, "case": str(REORDER_CASE)},
}
# the published split of generated layouts (cmdp_pymunk.cases.generated): train on the first,
# measure generalisation to an unseen floor on the second
GENERATED = {f"cmdp/GeneratedFloor-{split}{k}-v1": {"stage": 2, "case": str(path)}
             for split in ("train", "test") for k, path in enumerate(layout_files(split))}
VARIANTS.update(GENERATED)


# Gymnasium id -> default keyword arguments of decision_loop.make_decision_env (the stage-2
# decision env; case None: the built-in case). The event floor's: the same spaces, no low level.
DECISION_VARIANTS: dict[str, dict] = {
    "cmdp/TargetEvaluation-v1": {"fidelity": "pymunk"},
    "cmdp/TargetEvaluationEvent-v1": {"fidelity": "event"},
}


def make_parallel(**kwargs) -> CMDPEnv:
    """A registered variant as a PettingZoo ParallelEnv (``CMDPEnv``'s arguments)."""
    return CMDPEnv(**kwargs)


def make_aec(**kwargs):
    """A registered variant as a PettingZoo AEC env (``parallel_to_aec``)."""
    return parallel_to_aec(make_parallel(**kwargs))


def register_variants(variants: dict[str, dict] | None = None) -> None:
    """Register each variant under both APIs (``"parallel"`` and ``"aec"``)."""
    for env_id, kwargs in (VARIANTS if variants is None else variants).items():
        register("parallel", env_id, entry_point=f"{__name__}:make_parallel", kwargs=dict(kwargs))
        register("aec", env_id, entry_point=f"{__name__}:make_aec", kwargs=dict(kwargs))


def register_decision_variants(variants: dict[str, dict] | None = None) -> None:
    """Register each stage-2 decision env in Gymnasium's registry (``gymnasium.make``)."""
    for env_id, kwargs in (DECISION_VARIANTS if variants is None else variants).items():
        gymnasium.register(env_id, entry_point="cmdp_pymunk.adapters.decision_loop:"
                           "make_decision_env", kwargs=dict(kwargs))
