"""Version 2 of the reach-avoid environment (PettingZoo's versioned-module convention),
``reachavoid/ReachAvoid-v2``: the game of v1 with defaults for learning from scratch.

``parallel_env(**kwargs)`` is a ``decisions.DecisionEnv``; ``raw_env`` its AEC conversion;
``env`` the AEC env with PettingZoo's standard wrappers (clip actions; with
``continuous_actions=False`` assert they are in the space).

**Defaults, and why** (``benchmarks/v2_defaults.py`` measures them; the figures are in
BENCHMARKS.md):

- ``starts="random"``: every player's start is drawn at every reset, uniformly over the
  free space, from the env's seeded generator (``reset(seed=s)`` repeats it), so a learner
  sees the whole map rather than one start.
- ``decision_steps=10``: a decision lasts 10 physics steps of ``dt`` (50 ms in the paper's
  scenarios: an attacker moves 0.05 map units, half the capture radius, so a decision is
  still fine enough to dodge). Captures and arrivals are still judged on every physics
  step, by the env's own step; the decision stops at the sub-step the episode ends on.
  With one physics step per decision (v1) a random action moves a player 0.005 map units,
  and random play meets nothing (issue 51: 160 episodes of v1's default game, no capture
  and no arrival). Observations are taken once, at the end of the decision (an agent
  that left within it observes the game as the decision ends).
- ``max_cycles=400`` decisions (20 s of game in the paper's scenarios, four times v1's
  1000 physics steps). Measured on ``paper_2v1``, 200 seeded episodes
  (``benchmarks/v2_defaults.py``): random play meets a capture or an arrival in 47.5% of
  episodes (Wilson 95%: 40.7-54.4%), at 391.8 decisions per episode on average (an episode
  ends early only when no attacker is left); a shortest-path team against idle defenders
  first arrives at decision 12.9 on average, 37 at the latest, well within 400.
  ``decision_steps=20`` with ``max_cycles=200`` (the same 20 s) met events in 67% of
  episodes at 182.7 decisions each, but a decision of 0.1 map units equals the capture
  radius: too coarse to steer round a defender; 10 and 400 keep both aims.
- ``reward="sparse"`` (+1 arrival, -1 capture, the defenders minus the attackers' sum);
  ``reward="shaped"`` adds potential-based shaping ``F = gamma Phi(s') - Phi(s)`` (Ng,
  Harada and Russell 1999) with ``Phi`` minus an attacker's geodesic time to the target
  around the obstacles (``rewards.GeodesicPotential``; 0 once it is out of the game), and
  the defenders get minus the attackers' summed shaping (their potential is the
  attackers' summed time to go: still potential-based, the game still zero-sum). The
  discounted shaping of an episode telescopes to ``gamma^n Phi(s_n) - Phi(s_0)``, so the
  **optimal policies are unchanged**; use the learner's ``gamma`` (0.99 by default).
- ``continuous_actions=True``: ``Box(-1, 1, (2,))``; ``False`` gives MPE2's discrete form,
  ``Discrete(9)`` (stay, or 8 full-speed headings; ``actions``).
- ``remove_agents=True``: captured and arrived attackers leave ``agents``; ``False`` keeps
  every agent in ``agents`` until the episode ends (observation zeroed from the decision
  after it left, reward 0, ``active`` false, ``terminations`` / ``truncations`` false until
  the last decision), so SuperSuit's ``MarkovVectorEnv`` and fixed-size learners work
  without ``black_death``.
- numeric infos with the same keys for every agent from ``reset()`` on: ``captured``,
  ``arrived``, ``status``, ``captured_by`` (a defender's 0 and -1), ``active``.

Version History (``reachavoid/ReachAvoid-vN``, ``reach_avoid_vN``):

- v2: decisions of ``decision_steps`` physics steps, ``max_cycles`` counted in decisions,
  random starts, ``reward="shaped"``, discrete actions, ``remove_agents``, the same info
  keys for every agent (above). Observations, rules and the sparse reward as v1.
- v1: the egocentric observation by default (own position and velocity, the target's
  nearest point and signed distance, lidar rays to walls and obstacles, every other
  player's relative position, velocity and active flag, the time left;
  ``observations.ObservationConfig``); ``GameState.velocities``. Rules, rewards and infos
  as v0. Still available, bit for bit, as ``reach_avoid_v1``.
- v0: the global observation (every player's normalised position and active flag);
  numeric infos (``status`` codes, ``captured_by`` on every step) since the TorchRL work,
  readable ones with ``info_format="readable"``. Still available, bit for bit, as
  ``reach_avoid_v0`` / ``ReachAvoid-v0`` and ``observation=GLOBAL``.
"""

from typing import Any

from pettingzoo import AECEnv
from pettingzoo.utils import (
    AssertOutOfBoundsWrapper,
    ClipOutOfBoundsWrapper,
    OrderEnforcingWrapper,
    parallel_to_aec,
)

from reachavoid_env.decisions import DecisionEnv

__all__ = ["DecisionEnv", "env", "parallel_env", "raw_env"]


def parallel_env(**kwargs: Any) -> DecisionEnv:
    """The v2 parallel env; keyword arguments as ``DecisionEnv``."""
    return DecisionEnv(**kwargs)


def raw_env(**kwargs: Any) -> AECEnv:
    """The v2 AEC env converted from the parallel one, without wrappers."""
    return parallel_to_aec(DecisionEnv(**kwargs))


def env(**kwargs: Any) -> AECEnv:
    """The v2 AEC env with PettingZoo's standard wrappers (continuous actions clipped to
    the space, discrete ones asserted in it; call order enforced)."""
    aec = raw_env(**kwargs)
    bounded = ClipOutOfBoundsWrapper(aec) if kwargs.get("continuous_actions", True) \
        else AssertOutOfBoundsWrapper(aec)
    return OrderEnforcingWrapper(bounded)
