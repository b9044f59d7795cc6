"""Glue for RL libraries; each module imports its library, so import only the one you use.

- ``reachavoid_env.integrations.torchrl``: ``torchrl_env``, TorchRL's ``PettingZooWrapper``
  set up for agents that leave mid-episode (``rl`` extra).
- ``reachavoid_env.integrations.supersuit``: ``sb3_vec_env``, the SuperSuit chain that
  turns a ``ParallelEnv`` into a seeded Stable-Baselines3 ``VecEnv`` (``rl`` extra).
- ``reachavoid_env.integrations.benchmarl``: ``ReachAvoidTask``, a BenchMARL task for the
  game, and ``VectorGroupClass``, BenchMARL tasks over the vector training views
  (``benchmarl`` extra, in a virtual environment of its own; the task with scripted
  defenders is ``reachavoid.training.benchmarl_task``).

``import reachavoid_env`` imports none of them, so the core package needs none of these
libraries.
"""
