"""The training views with named scripted policies: the factories of the Gymnasium /
PettingZoo ids (``reachavoid_env.training_ids`` registers them, with entry points into
this module) and the vector views the recipes train on.

``reachavoid_env.wrappers`` and ``reachavoid_env.vector_views`` take policy objects; this
module names them (``policies.registry``), so an env can be made from strings (on the
command line, in a registry id, in a subprocess):

    from reachavoid.training.views import make_attacker_env
    env = make_attacker_env("paper_2v1", defenders="hj",
                            defender_options={"grid1": 31, "grid2": 15})

Importing ``reachavoid_env`` registers, once Gymnasium is imported (``make_attacker_env``,
one learning attacker):

- ``reachavoid/Attacker-v1`` (``scenario=`` keyword, default ``paper_2v1``; a map library
  folder or index trains across its maps, one drawn per reset, with the defenders built
  per map);
- ``reachavoid/Attacker-<builtin>-v1`` for every built-in scenario, e.g.
  ``reachavoid/Attacker-paper_2v1-v1`` (the scenario's starts);
- ``reachavoid/Attacker-<builtin>-random-v1``: the same map and player counts with
  random starts at every reset (``starts="random"``), e.g.
  ``reachavoid/Attacker-paper_6v2-random-v1`` for 6 vs 2;

and for PettingZoo (``pettingzoo.make("parallel", ...)``, ``make_attackers_parallel_env``,
every attacker learning; PettingZoo 1.27 on) ``reachavoid/Attackers-v1`` (``scenario=``
keyword) and ``reachavoid/Attackers-<builtin>-v1`` /
``reachavoid/Attackers-<builtin>-random-v1`` likewise (``reachavoid_env.training_ids``:
``GYM_ID``, ``PETTINGZOO_ID``, ``gym_id``, ``pettingzoo_id``). Every id takes
``starts="random"`` as a keyword too. Without importing anything first, Gymnasium's
``"module:id"`` form loads them:
``gymnasium.make("reachavoid_env:reachavoid/Attacker-paper_2v1-random-v1")``.

Version history: ``-v1`` observe the egocentric observation (``ReachAvoid-v1``: target,
lidar, the others relative to the agent); the same ids ending ``-v0`` remain, with v0's
global observation (``observation={"egocentric": False}``). Keyword arguments of
``gymnasium.make`` / ``make_vec`` / ``pettingzoo.make`` go to the factory.

Defenders default to ``"hj"``, the paper's HJ + MIP defenders
(``HJDefenderPolicy.for_scenario``): the first env of a game solves its HJ tubes and
caches them on disk (design.md section 4); later envs, subprocesses included, load them.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import Any

from policies.registry import PolicySpec, make_batch_policy
from reachavoid_env import checks
from reachavoid_env.maps import ScenarioSource
from reachavoid_env.policy import BatchPolicy, PerCopy, PerMap
from reachavoid_env.vector import ReachAvoidVectorEnv
from reachavoid_env.vector_views import LearnerVectorEnv
from reachavoid_env.wrappers import AttackerParallelEnv, SingleAttackerEnv


def defender_factory(name: str = "hj", **options: Any) -> PolicySpec:
    """Factory of the defender policy ``name`` (a spec of ``policies.registry``) with
    ``options``."""
    return PolicySpec.of("defenders", name, **options)


def attacker_factory(name: str = "shortest-path", **options: Any) -> PolicySpec:
    """Factory of the attacker policy ``name`` (a spec of ``policies.registry``) with
    ``options``."""
    return PolicySpec.of("attackers", name, **options)


def _source(value: Any, options: Mapping[str, Any] | None, side: str, field: str) -> Any:
    """A name becomes its factory; a policy or factory passes through."""
    if isinstance(value, str):
        return PolicySpec.of(side, value, **(options or {}))
    if options:
        raise ValueError(f"{field}_options: only used with a policy name, got a "
                         f"{type(value).__name__} for {field}")
    return value


def make_attacker_env(scenario: ScenarioSource = "paper_2v1", defenders: Any = "hj",
                      teammates: Any = "shortest-path",
                      defender_options: Mapping[str, Any] | None = None,
                      teammate_options: Mapping[str, Any] | None = None,
                      **env_kwargs: Any) -> SingleAttackerEnv:
    """A ``SingleAttackerEnv``: one learning attacker against scripted defenders.

    ``defenders`` / ``teammates``: a policy name (``DEFENDERS`` / ``ATTACKERS``, built with
    ``defender_options`` / ``teammate_options``), a policy object or a factory
    ``scenario -> policy``. Teammates play only where the scenario has more than one
    attacker. ``env_kwargs``: ``starts`` (``"random"``: new starts at every reset),
    ``attacker``, ``max_cycles``, ``render_mode``, ``shaping``, ``timeout_reward``,
    ``action_repeat``, ``scripted_every``, ``render_width``, ``info_format``
    (``SingleAttackerEnv``).
    """
    return SingleAttackerEnv(
        _source(defenders, defender_options, "defenders", "defender"), scenario=scenario,
        teammates=_source(teammates, teammate_options, "attackers", "teammate"), **env_kwargs)


def make_attackers_parallel_env(scenario: ScenarioSource = "paper_2v1", defenders: Any = "hj",
                                defender_options: Mapping[str, Any] | None = None,
                                **env_kwargs: Any) -> AttackerParallelEnv:
    """An ``AttackerParallelEnv``: every attacker learns, ``defenders`` (a name, a policy or
    a factory, as in ``make_attacker_env``) moves the defenders. ``env_kwargs``:
    ``starts`` (``"random"``: new starts at every reset), ``max_cycles``, ``render_mode``,
    ``shaping``, ``timeout_reward``, ``team_reward``, ``action_repeat``, ``scripted_every``,
    ``render_width``, ``info_format`` (``AttackerParallelEnv``)."""
    return AttackerParallelEnv(_source(defenders, defender_options, "defenders", "defender"),
                               scenario=scenario, **env_kwargs)


def batch_policy(source: Any, options: Mapping[str, Any] | None, side: str, field: str,
                 vec: ReachAvoidVectorEnv) -> BatchPolicy:
    """A ``BatchPolicy`` for the scripted ``side`` of ``vec``'s copies: a ``BatchPolicy``
    as it is; a name through ``make_batch_policy`` (its batched class where it has one: all
    copies of a map in one call), one per map over several maps (``PerMap``); otherwise a
    factory ``scenario -> policy`` asked copy by copy (``PerCopy``)."""
    if isinstance(source, BatchPolicy):
        return source
    if isinstance(source, str):
        options = dict(options or {})
        if len(vec.scenarios) == 1:
            return make_batch_policy(side, source, vec.base_scenario, **options)
        PolicySpec.of(side, source, **options)   # a wrong name or option fails here, once
        return PerMap(functools.partial(make_batch_policy, side, source, **options))
    built = _source(source, options, side, field)
    if not callable(built) or isinstance(built, type):
        raise TypeError(f"{field}s: the vector env needs a name, a factory scenario -> policy "
                        f"or a BatchPolicy, got {type(source).__name__}")
    return PerCopy(built, side)


def make_attackers_vector_env(scenario: ScenarioSource = "paper_2v1", defenders: Any = "hj",
                              num_envs: int = 16,
                              defender_options: Mapping[str, Any] | None = None,
                              action_repeat: int = 1, timeout_reward: float = 0.0,
                              autoreset: bool = True, team_reward: float = 0.0,
                              **env_kwargs: Any) -> LearnerVectorEnv:
    """Every attacker of ``num_envs`` copies learns (``LearnerVectorEnv``, arrays
    ``(K, M, ...)``, ``team_reward`` as there); ``defenders`` (a name, a factory or a
    ``BatchPolicy``) move the defenders of every copy. ``autoreset=False`` for TorchRL
    (``integrations.torchrl.VectorGroupEnv``). ``env_kwargs``: ``starts``
    (``"random"`` by default), ``max_cycles``, ``shaping``, ``observation``,
    ``copies_per_map`` (``ReachAvoidVectorEnv``)."""
    vec = ReachAvoidVectorEnv(scenario, num_envs=num_envs, autoreset=False, **env_kwargs)
    base = vec.base_scenario
    return LearnerVectorEnv(
        vec, base.attacker_names,
        [(batch_policy(defenders, defender_options, "defenders", "defender", vec),
          base.defender_names)], action_repeat=action_repeat, timeout_reward=timeout_reward,
        autoreset=autoreset, team_reward=team_reward)


def make_defenders_vector_env(scenario: ScenarioSource = "paper_2v1",
                              attackers: Any = "shortest-path", num_envs: int = 16,
                              attacker_options: Mapping[str, Any] | None = None,
                              action_repeat: int = 1, autoreset: bool = True,
                              **env_kwargs: Any) -> LearnerVectorEnv:
    """Every defender of ``num_envs`` copies learns (arrays ``(K, N, ...)``); ``attackers``
    (a name, a factory or a ``BatchPolicy``) move the attackers of every copy: the view a
    learned defender trains on. ``env_kwargs`` as ``make_attackers_vector_env``."""
    vec = ReachAvoidVectorEnv(scenario, num_envs=num_envs, autoreset=False, **env_kwargs)
    base = vec.base_scenario
    return LearnerVectorEnv(
        vec, base.defender_names,
        [(batch_policy(attackers, attacker_options, "attackers", "attacker", vec),
          base.attacker_names)], action_repeat=action_repeat, autoreset=autoreset)


def make_attacker_vector_env(scenario: ScenarioSource = "paper_2v1", defenders: Any = "hj",
                             teammates: Any = "shortest-path", num_envs: int = 16,
                             attacker: int = 0,
                             defender_options: Mapping[str, Any] | None = None,
                             teammate_options: Mapping[str, Any] | None = None,
                             action_repeat: int = 1, timeout_reward: float = 0.0,
                             **env_kwargs: Any) -> LearnerVectorEnv:
    """One learning attacker (``attacker_{attacker}``) in each of ``num_envs`` copies, as
    ``make_attacker_env`` has it (its episode ends when it leaves), against scripted
    defenders and teammates (names, factories or ``BatchPolicy`` objects). Wrap it in
    ``integrations.vector.GymVectorEnv`` for Gymnasium's vector API."""
    vec = ReachAvoidVectorEnv(scenario, num_envs=num_envs, autoreset=False, **env_kwargs)
    base = vec.base_scenario
    checks.integer(attacker, "attacker", 0, base.num_attackers - 1)
    learner = base.attacker_names[attacker]
    scripted = [(batch_policy(defenders, defender_options, "defenders", "defender", vec),
                 base.defender_names)]
    others = [name for name in base.attacker_names if name != learner]
    if others:
        scripted.append((batch_policy(teammates, teammate_options, "attackers", "teammate", vec),
                         others))
    return LearnerVectorEnv(vec, [learner], scripted, action_repeat=action_repeat,
                            timeout_reward=timeout_reward)
