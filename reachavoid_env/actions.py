"""The agents' action spaces: continuous velocities, or MPE2's discrete choice
(``continuous_actions=False``): stay, or one of ``HEADINGS`` full-speed headings.

``Discrete(HEADINGS + 1)``: action 0 stands still; action ``i >= 1`` moves at full speed
towards the angle ``2 pi (i - 1) / HEADINGS`` (counter-clockwise from +x: 1 east, 3
north, 5 west, 7 south). ``controls`` turns discrete actions into the continuous
actions the game steps with, so every view (the v2 env, its AEC form, the vector env
and the training views) shares the one table.
"""

from __future__ import annotations

import numbers
from typing import Any

import gymnasium
import numpy as np

HEADINGS = 8
"""Full-speed headings of a discrete action (plus stay): 45 degrees apart, as MPE2's
five actions (stay and four) refined to the diagonals."""

_ANGLES = 2 * np.pi * np.arange(HEADINGS) / HEADINGS
TABLE = np.concatenate([np.zeros((1, 2)),
                        np.stack([np.cos(_ANGLES), np.sin(_ANGLES)], axis=-1)])
"""``(HEADINGS + 1, 2)``: the continuous action of each discrete one (row 0: stay)."""
TABLE.setflags(write=False)


def action_space(continuous: bool) -> gymnasium.spaces.Space:
    """One agent's action space.

    Args:
        continuous: ``True`` for ``Box(-1, 1, (2,), float32)`` (a velocity as a fraction of
            the player's speed), ``False`` for ``Discrete(HEADINGS + 1)``.

    Returns:
        A new space object (an env keeps one per agent).
    """
    if continuous:
        return gymnasium.spaces.Box(-1.0, 1.0, (2,), np.float32)
    return gymnasium.spaces.Discrete(HEADINGS + 1)


def control(agent: str, action: Any) -> np.ndarray:
    """The continuous action ``(2,)`` of one agent's discrete ``action``.

    Args:
        agent: the agent's name (for the message).
        action: an integer in ``0..HEADINGS`` (a Python or numpy integer, or an integer
            array of one element).

    Returns:
        The row of ``TABLE`` (read-only).

    Raises:
        ValueError: naming ``agent`` when ``action`` is not such an integer.
    """
    value = action
    if isinstance(action, np.ndarray) and action.size == 1 and action.dtype.kind in "iu":
        value = action.reshape(()).item()
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) \
            or not 0 <= int(value) <= HEADINGS:
        raise ValueError(f"action for {agent}: expected an integer in 0..{HEADINGS} "
                         f"(discrete actions), got {action!r}")
    return TABLE[int(value)]


def controls(field: str, actions: Any, shape: tuple[int, ...]) -> np.ndarray:
    """The continuous actions ``(*shape, 2)`` of an array of discrete ones (the vector env's
    and the training views' batches).

    Args:
        field: what the actions are (for the message), e.g. ``"action for attacker_0"``.
        actions: integers in ``0..HEADINGS`` of shape ``shape``.
        shape: the expected shape.

    Returns:
        ``TABLE`` rows, float64.

    Raises:
        ValueError: naming ``field`` for another shape, a non-integer dtype or a value out
            of range.
    """
    array = np.asarray(actions)
    if array.dtype.kind not in "iu" or array.shape != shape \
            or (array.size and (array.min() < 0 or array.max() > HEADINGS)):
        raise ValueError(f"{field}: expected integers in 0..{HEADINGS} of shape {shape} "
                         f"(discrete actions), got {array.dtype} of shape {array.shape}")
    return TABLE[array]
