"""cmdp-pymunk: the Construction Markov Decision Process on pymunk, as a PettingZoo env."""

from .case import BUILTIN_CASE, Case, CaseError, load_case
from .env import CMDPEnv

__version__ = "0.1.0"


def parallel_env(**kwargs) -> CMDPEnv:
    """The CMDP as a PettingZoo ParallelEnv; see ``cmdp_pymunk.env`` for its arguments."""
    return CMDPEnv(**kwargs)


__all__ = ["parallel_env", "CMDPEnv", "Case", "CaseError", "load_case", "BUILTIN_CASE"]
