"""The policy protocol: what the env loop, the CLI and the benchmarks drive."""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from reachavoid_env import GameState, Overlay, Scenario


@runtime_checkable
class Policy(Protocol):
    """Controls one side (all attackers or all defenders) of a game.

    ``act`` returns an action for every live agent it controls, keyed by agent name: a
    float32 array ``(2,)`` in ``[-1, 1]``, the desired velocity as a fraction of that
    player's speed (the env's action space). ``overlay`` is optional: policies that have
    something to show (assignment edges) return an ``Overlay`` for the renderer.
    """

    def reset(self, scenario: Scenario) -> None: ...

    def act(self, state: GameState) -> dict[str, np.ndarray]: ...


def overlay_of(policy: object) -> Overlay | None:
    """The policy's overlay if it draws one, else ``None``."""
    overlay = getattr(policy, "overlay", None)
    return overlay() if callable(overlay) else None
