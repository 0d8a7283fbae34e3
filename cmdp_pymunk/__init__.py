"""cmdp-pymunk: the Construction Markov Decision Process on pymunk, as a PettingZoo env.

The simulation core (``engine``, ``cases``, ``state``, ``decide``, ...) imports neither
PettingZoo nor Gymnasium: ``import cmdp_pymunk.engine`` works without them. Where PettingZoo is
installed, importing the package registers the env's variants (``pettingzoo.make("parallel",
"cmdp/PrecastFloor-v1")``) and the stage-2 decision envs in Gymnasium's registry
(``gymnasium.make("cmdp/TargetEvaluationEvent-v1")``); ``CMDPEnv``, ``parallel_env`` and
``env`` load the adapter on use.
"""

from .about import ENV_NAME, __version__, add_version_flag
from .cases.load import (
    BUILTIN_CASE,
    DISRUPTED_CASE,
    REORDER_CASE,
    TINY_CASE,
    Case,
    CaseError,
    load_case,
)


def parallel_env(**kwargs):
    """The CMDP as a PettingZoo ParallelEnv; see ``cmdp_pymunk.adapters.env`` for its arguments."""
    from .adapters.env import CMDPEnv

    return CMDPEnv(**kwargs)


def env(**kwargs):
    """The CMDP as a PettingZoo AECEnv (``parallel_to_aec`` over ``parallel_env``)."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(**kwargs))


def __getattr__(name: str):
    if name == "CMDPEnv":  # the adapter, loaded on use (it needs PettingZoo)
        from .adapters.env import CMDPEnv

        return CMDPEnv
    raise AttributeError(f"module 'cmdp_pymunk' has no attribute {name!r}")


try:  # the variants in PettingZoo's registry, as its users expect, where it is installed
    import pettingzoo  # noqa: F401
except ImportError:
    pass
else:
    from .adapters import registry as _registry

    _registry.register_variants()
    _registry.register_decision_variants()


__all__ = ["parallel_env", "env", "add_version_flag", "__version__", "CMDPEnv", "Case", "CaseError",
           "load_case", "BUILTIN_CASE", "TINY_CASE", "DISRUPTED_CASE", "REORDER_CASE",
           "ENV_NAME"]
