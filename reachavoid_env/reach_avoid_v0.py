"""Version 0 of the reach-avoid environment (PettingZoo's versioned-module convention):
the global observation (``observations.GLOBAL``: every player's absolute position and
active flag), as it was before v1, bit for bit.

``parallel_env(**kwargs)`` is a ``ReachAvoidEnv`` with ``observation=GLOBAL`` unless the
keywords say otherwise; ``raw_env`` its AEC conversion; ``env`` the AEC env with the
standard wrappers.
"""

from typing import Any

from pettingzoo import AECEnv

from reachavoid_env import environment
from reachavoid_env.environment import ReachAvoidEnv
from reachavoid_env.observations import GLOBAL

__all__ = ["ReachAvoidEnv", "env", "parallel_env", "raw_env"]


def parallel_env(**kwargs: Any) -> ReachAvoidEnv:
    """The v0 parallel env; keyword arguments as ``ReachAvoidEnv``."""
    return environment.parallel_env(**{"observation": GLOBAL, **kwargs})


def raw_env(**kwargs: Any) -> AECEnv:
    """The v0 AEC env converted from the parallel one, without wrappers."""
    return environment.raw_env(**{"observation": GLOBAL, **kwargs})


def env(**kwargs: Any) -> AECEnv:
    """The v0 AEC env with PettingZoo's standard wrappers."""
    return environment.env(**{"observation": GLOBAL, **kwargs})
