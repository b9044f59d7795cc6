"""The ids of the attacker training envs, registered with Gymnasium and PettingZoo as soon
as both this package and the library are imported (``reachavoid_env.lazy.after_import``),
so ``import reachavoid_env`` is all a training script needs before ``gymnasium.make``.

The entry points are strings into ``reachavoid.training.views`` (the application's training
views, which name the scripted policies): registering imports nothing above this package,
and nothing of the application is imported until an env is made. Registration lives here,
in the lowest layer, so that the ids exist without importing ``policies`` or ``reachavoid``.
Ids (``reachavoid.training.views`` has the factories' keywords):

- Gymnasium (one learning attacker): ``reachavoid/Attacker-v1`` (``scenario=`` keyword),
  ``reachavoid/Attacker-<builtin>-v1`` and ``reachavoid/Attacker-<builtin>-random-v1``
  (random starts at every reset) for every built-in scenario;
- PettingZoo 1.27 on (every attacker learning): ``reachavoid/Attackers-v1``,
  ``reachavoid/Attackers-<builtin>-v1``, ``reachavoid/Attackers-<builtin>-random-v1``;

and each again ending ``-v0`` with v0's global observation.
"""

from __future__ import annotations

from typing import Any

from reachavoid_env.scenario import builtin_names

GYM_ID = "reachavoid/Attacker-v1"
PETTINGZOO_ID = "reachavoid/Attackers-v1"
_VERSIONS: dict[int, dict[str, Any]] = {1: {}, 0: {"observation": {"egocentric": False}}}
_STARTS_SUFFIX = {"scenario": "", "random": "-random"}


def gym_id(scenario: str, starts: str = "scenario", version: int = 1) -> str:
    """The Gymnasium id of the single-attacker env of built-in ``scenario``.

    Args:
        scenario: a built-in scenario's name.
        starts: ``"scenario"`` or ``"random"``, as ``ReachAvoidEnv``.
        version: 1 (egocentric observation) or 0 (global).

    Returns:
        e.g. ``reachavoid/Attacker-paper_6v2-random-v1``.
    """
    return f"reachavoid/Attacker-{scenario}{_STARTS_SUFFIX[starts]}-v{version}"


def pettingzoo_id(scenario: str, starts: str = "scenario", version: int = 1) -> str:
    """The PettingZoo id of the attacker-only env of built-in ``scenario`` (arguments as
    ``gym_id``)."""
    return f"reachavoid/Attackers-{scenario}{_STARTS_SUFFIX[starts]}-v{version}"


def _ids(default_id: str, id_of: Any) -> dict[str, dict[str, Any]]:
    """``default_id`` (no keywords) and ``id_of(builtin, starts, version)`` of every
    built-in, starts and version, with their keywords."""
    ids: dict[str, dict[str, Any]] = {}
    for version, kwargs in _VERSIONS.items():
        ids[default_id.replace("-v1", f"-v{version}")] = kwargs
        ids |= {id_of(name, starts, version): {"scenario": name, "starts": starts, **kwargs}
                for name in builtin_names() for starts in _STARTS_SUFFIX}
    return ids


def register_gymnasium(gymnasium: Any) -> None:
    """Register the Gymnasium ids (again: a no-op).

    Args:
        gymnasium: the imported ``gymnasium`` module.
    """
    for env_id, kwargs in _ids(GYM_ID, gym_id).items():
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point="reachavoid.training.views:make_attacker_env",
                               kwargs=kwargs)


def register_pettingzoo(pettingzoo: Any) -> None:
    """Register the PettingZoo ids (again: a no-op; PettingZoo before 1.27 has no
    registry, and nothing is done).

    Args:
        pettingzoo: the imported ``pettingzoo`` module.
    """
    if not hasattr(pettingzoo, "register"):
        return
    for env_id, kwargs in _ids(PETTINGZOO_ID, pettingzoo_id).items():
        if env_id not in pettingzoo.parallel_registry:
            pettingzoo.register("parallel", env_id, kwargs=kwargs,
                                entry_point="reachavoid.training.views:make_attackers_parallel_env")
