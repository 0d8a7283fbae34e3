"""cmdp-pymunk: the Construction Markov Decision Process on pymunk, as a PettingZoo env."""

from . import registry as _registry
from .case import BUILTIN_CASE, DISRUPTED_CASE, TINY_CASE, Case, CaseError, load_case
from .env import CMDPEnv

__version__ = "0.2.0"


def add_version_flag(parser) -> None:
    """``--version`` on a command-line parser: the package version and the env's name."""
    from .env import CMDPEnv as _Env

    parser.add_argument("--version", action="version",
                        version=f"%(prog)s {__version__} ({_Env.metadata['name']})")


def parallel_env(**kwargs) -> CMDPEnv:
    """The CMDP as a PettingZoo ParallelEnv; see ``cmdp_pymunk.env`` for its arguments."""
    return CMDPEnv(**kwargs)


def env(**kwargs):
    """The CMDP as a PettingZoo AECEnv (``parallel_to_aec`` over ``parallel_env``)."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(CMDPEnv(**kwargs))


# The variants in PettingZoo's registry: pettingzoo.make("parallel", "cmdp/PrecastFloor-v1")
_registry.register_variants()


__all__ = ["parallel_env", "env", "add_version_flag", "__version__", "CMDPEnv", "Case", "CaseError",
           "load_case", "BUILTIN_CASE", "TINY_CASE", "DISRUPTED_CASE"]
