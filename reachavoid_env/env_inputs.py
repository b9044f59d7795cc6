"""What callers hand an env, checked: the scenario library, reset options, actions and
agent names, and the observation config (``ReachAvoidEnv`` and the vector env share
these)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from reachavoid_env import checks
from reachavoid_env.actions import controls
from reachavoid_env.maps import load_library
from reachavoid_env.observations import ObservationConfig
from reachavoid_env.scenario import Scenario, ScenarioError

INFO_FORMATS = ("numeric", "readable")
STARTS = ("scenario", "random")
_RESET_OPTIONS = ("scenario", "attackers", "defenders", "attacker_reach")


REAL_KINDS = ("i", "u", "f")
"""numpy dtype kinds of real numbers (not bool, complex, strings or objects)."""


def stack_actions(live: Sequence[str], actions: Mapping[str, Any]) -> np.ndarray:
    """The ``live`` agents' actions as a ``(L, 2)`` float64 array (fractions of the
    player's speed, x then y), checked: a missing agent is a ``KeyError``, an action that
    is not a finite 2-vector of real numbers a ``ValueError`` naming the agent."""
    for name in live:
        if name not in actions:
            raise KeyError(f"step: no action for live agent {name!r}")
        if getattr(getattr(actions[name], "dtype", None), "kind", "") not in REAL_KINDS:
            _checked_action(name, actions[name])   # a list, or not real numbers: refused
    try:
        stacked = np.array([actions[name] for name in live], dtype=np.float64)
    except (TypeError, ValueError):
        stacked = None
    if stacked is None or stacked.shape != (len(live), 2) \
            or not np.isfinite(stacked).all():
        stacked = np.array([_checked_action(name, actions[name]) for name in live])
    return stacked


def vector_actions(actions: Any, agents: Sequence[str], copies: int,
                   continuous: bool) -> np.ndarray:
    """The vector env's actions ``{agent: (K, 2)}`` (``continuous``; else ``{agent: (K,)}``
    discrete ones through ``actions.TABLE``) as every player's control ``(K, P, 2)``
    float64, fractions of the speed, checked (errors name the agent)."""
    if not isinstance(actions, Mapping):
        raise TypeError(f"step: actions must be a dict {{agent name: (K, 2) array}}, got "
                        f"{type(actions).__name__}")
    check_agent_names(actions, agents)
    stacked = np.empty((copies, len(agents), 2))
    for i, name in enumerate(agents):
        if name not in actions:
            raise KeyError(f"step: no action for agent {name!r}")
        array = np.asarray(actions[name])
        if not continuous:
            stacked[:, i] = controls(f"action for {name}", array, (copies,))
        elif array.dtype.kind not in REAL_KINDS or array.shape != (copies, 2) \
                or not np.isfinite(array).all():
            raise ValueError(f"action for {name}: expected finite real numbers of shape "
                             f"({copies}, 2), got {array.dtype} of shape {array.shape}")
        else:
            stacked[:, i] = array
    return stacked


def _real_number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) \
        and not isinstance(value, (bool, np.bool_))


def _checked_action(agent: str, action: Any) -> np.ndarray:
    """``action`` as a float64 ``(2,)`` array; ``ValueError`` naming ``agent`` if it is not
    a finite 2-vector of real numbers (an array of a real dtype, or a sequence of ints and
    floats: not strings, booleans or complex numbers, which numpy would convert)."""
    kind = getattr(getattr(action, "dtype", None), "kind", None)
    if kind == "c" or isinstance(action, complex):
        raise ValueError(f"action for {agent}: expected real numbers, got complex {action!r}")
    if kind is None:
        real = not isinstance(action, (str, bytes)) and all(map(_real_number, _items(action)))
    else:
        real = kind in REAL_KINDS
    if not real:
        raise ValueError(f"action for {agent}: expected a 2-vector of real numbers, "
                         f"got {action!r}")
    try:
        array = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"action for {agent}: expected a 2-vector of numbers, "
                         f"got {action!r}") from None
    if array.shape != (2,):
        raise ValueError(f"action for {agent}: expected shape (2,), got {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"action for {agent}: must be finite, got {array.tolist()}")
    return array


def _items(action: Any) -> list[Any]:
    """The elements of a sequence ``action`` (``[action]`` for anything else)."""
    try:
        return list(action)
    except TypeError:
        return [action]


def check_agent_names(actions: dict[str, Any], agents: Sequence[str]) -> None:
    """``KeyError`` naming the first key of ``actions`` that is not one of ``agents``."""
    for name in actions:
        if name not in agents:
            raise KeyError(f"step: {name!r} is not an agent of this env "
                           f"(agents: {', '.join(agents)})")


def draw_scenario(scenarios: Sequence[Scenario], rng: np.random.Generator,
                  ) -> tuple[Scenario, int]:
    """The scenario of an episode and its index: one drawn with ``rng`` from a library of
    several maps, the only one otherwise (no draw)."""
    index = int(rng.integers(len(scenarios))) if len(scenarios) > 1 else 0
    return scenarios[index], index


def episode_scenario(scenarios: Sequence[Scenario], options: Mapping[str, Any],
                     rng: np.random.Generator, attackers: int, defenders: int) -> Scenario:
    """The scenario of an episode of ``ReachAvoidEnv``: ``options["scenario"]`` (with
    ``attackers`` and ``defenders`` players) or one drawn from ``scenarios``
    (``draw_scenario``), with the start positions ``options`` gives (``checked_options``)."""
    if "scenario" not in options:
        scenario = draw_scenario(scenarios, rng)[0]
    else:
        scenario = options["scenario"]
        if not isinstance(scenario, Scenario):
            raise TypeError(f"options['scenario']: expected a Scenario, "
                            f"got {type(scenario).__name__}")
        if (scenario.num_attackers, scenario.num_defenders) != (attackers, defenders):
            raise ValueError(
                f"options['scenario']: has {scenario.num_attackers} attackers and "
                f"{scenario.num_defenders} defenders; this env has {attackers} and {defenders}")
    for role, count in (("attackers", attackers), ("defenders", defenders)):
        if options.get(role) is not None:
            points = _start_points(options[role], count, role)
            scenario = replace(scenario, **{role: points})
    return scenario


def library(source: Any, starts: str) -> tuple[Scenario, ...]:
    """The scenarios an env plays (``maps.load_library``), checked to share the player
    counts (the spaces depend on them); with ``starts="random"`` without start positions,
    so that every reset draws them."""
    scenarios = load_library(source)
    first = scenarios[0]
    for scenario in scenarios[1:]:
        if (scenario.num_attackers, scenario.num_defenders) != (first.num_attackers,
                                                                first.num_defenders):
            raise ScenarioError(f"scenario: {scenario.name!r} has {scenario.num_attackers} "
                                f"attackers and {scenario.num_defenders} defenders, "
                                f"{first.name!r} {first.num_attackers} and "
                                f"{first.num_defenders}; a library's maps share the counts")
    if starts == "random":
        scenarios = tuple(s.with_players(s.num_attackers, s.num_defenders) for s in scenarios)
    return scenarios


def checked_options(options: Any) -> dict[str, Any]:
    """``options`` as a dict; an unknown key is a ``ValueError`` naming it (a typo must not
    silently give random starts). PettingZoo's API tests probe ``reset`` with
    ``{"options": 1}``; that one key is accepted and ignored so that ``pettingzoo.test``
    runs on this env."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise TypeError(f"reset: options must be a dict with keys from {_RESET_OPTIONS}, "
                        f"got {type(options).__name__}")
    unknown = sorted(str(key) for key in options if key not in _RESET_OPTIONS + ("options",))
    if unknown:
        raise ValueError(f"reset: options[{unknown[0]!r}] is not an option (accepted: "
                         f"{', '.join(_RESET_OPTIONS)})")
    if options.get("attacker_reach") is not None:
        checks.positive(options["attacker_reach"], "options['attacker_reach']")
    return options


def _start_points(value: Any, count: int, role: str) -> tuple[tuple[float, float], ...]:
    try:
        points = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"options['{role}']: expected an array of shape ({count}, 2)") from None
    if points.shape != (count, 2):
        raise ValueError(f"options['{role}']: expected shape ({count}, 2), got {points.shape}")
    for i, p in enumerate(points):
        if not np.isfinite(p).all():
            raise ValueError(f"options['{role}'][{i}] ({role[:-1]}_{i}): must be finite, "
                             f"got {p.tolist()}")
    return tuple((float(x), float(y)) for x, y in points)


def name_player(err: ScenarioError, attackers: int, defenders: int) -> str:
    """The message of ``err``, with the agent's name when its field is one player's start
    (``players.attackers[i]``)."""
    agents = {f"players.{role}s[{i}]": f"{role}_{i}"
              for role, count in (("attacker", attackers), ("defender", defenders))
              for i in range(count)}
    agent = agents.get(err.field or "")
    return f"{err} ({agent})" if agent else str(err)


def observation_config(value: ObservationConfig | Mapping[str, Any] | None,
                       ) -> ObservationConfig:
    """``value`` as an ``ObservationConfig``: itself, the default (``None``), or built from
    a dict of its fields (an unknown key is a ``ValueError`` naming it)."""
    if value is None:
        return ObservationConfig()
    if isinstance(value, ObservationConfig):
        return value
    if isinstance(value, Mapping):
        fields = ObservationConfig.__dataclass_fields__
        for key in value:
            if key not in fields:
                raise ValueError(f"observation.{key}: not an option (accepted: "
                                 f"{', '.join(fields)})")
        return ObservationConfig(**value)
    raise TypeError(f"observation: expected an ObservationConfig or a dict, got "
                    f"{type(value).__name__}")
