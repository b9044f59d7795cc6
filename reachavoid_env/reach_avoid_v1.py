"""Version 1 of the reach-avoid environment (PettingZoo's versioned-module convention):
the egocentric observation (``observations.ObservationConfig()``: own state, the target,
lidar rays, the others relative to the agent, the time left).

``parallel_env(**kwargs)`` is the ``ReachAvoidEnv`` itself; ``raw_env`` its AEC
conversion; ``env`` the AEC env with the standard wrappers.
"""

from reachavoid_env.environment import ReachAvoidEnv, env, parallel_env, raw_env

__all__ = ["ReachAvoidEnv", "env", "parallel_env", "raw_env"]
