"""The learned defenders ``learned-mappo``: a MAPPO actor shared by every defender, played
with numpy from a small weights file (no torch at play time).

    from policies.registry import make_policy
    defenders = make_policy("defenders", "learned-mappo", scenario)

The actor reads each defender's egocentric observation (``ReachAvoid-v1``'s default,
``reachavoid_env.observations``, through ``ObservationPolicy``), rearranged into one
**padded layout** that fits every game of up to ``MAX_ATTACKERS`` attackers and
``MAX_DEFENDERS`` defenders, so one network plays 1v1 to 8v4::

    [own x, y, vx, vy, target dx, dy, distance, lidar_0 .. lidar_{R-1},    as observed
     MAX_DEFENDERS - 1 teammate blocks, MAX_ATTACKERS opponent blocks,     (dx, dy, vx, vy,
                                                                            active) each
     time left]

Within each group the blocks are sorted: players in the game first, nearest first (ties
keep agent order), then zero blocks for the players the game does not have. A game with
more players than that, or an observation without velocities or time left, is refused
(``PolicyMismatch``, one line naming the scenario).

The weights (``WEIGHTS``, package data) are an ``.npz`` of float32 arrays read with
``allow_pickle=False``: ``w0, b0, w1, b1, ...`` (weights ``(in, out)``; ``tanh`` after
every layer, the last one's outputs the action's mean before its ``tanh``), and ``meta``
``[FORMAT, lidar_rays, action_repeat]``. ``load_weights`` checks the sizes the file expands
to (``MAX_WEIGHTS_BYTES``) before reading it, then every array; a missing, damaged or
oversized file is a one-line ``ValueError``. ``reachavoid/training/mappo.py`` makes them
(``examples/train_defender_mappo.py``, ``docs/training.md``).
"""

from __future__ import annotations

import zipfile
from importlib import resources
from pathlib import Path
from typing import NamedTuple

import numpy as np

from policies.learned import ObservationPolicy
from reachavoid_env import PolicyMismatch, Scenario
from reachavoid_env.files import atomic_write
from reachavoid_env.observations import ObservationConfig

MAX_ATTACKERS = 8
MAX_DEFENDERS = 4
BLOCK = 5
"""Entries of one other player's block: dx, dy, vx, vy, active."""
FORMAT = 1
"""The weights file's format (``meta[0]``)."""
WEIGHTS = "learned_mappo.npz"
"""The shipped weights, under ``policies/weights/``."""
MAX_WEIGHTS_BYTES = 64 << 20
"""The most bytes a weights file's arrays may hold, as its zip directory says, checked
before any is read: a small file that expands far beyond an actor is refused."""


class ActorWeights(NamedTuple):
    """The actor's layers and how it observes and acts.

    ``layers``: ``(weight (in, out), bias (out,))`` float32 pairs, ``tanh`` after each;
    ``lidar_rays``: the observation's rays; ``action_repeat``: env steps an action is held.
    """

    layers: tuple[tuple[np.ndarray, np.ndarray], ...]
    lidar_rays: int
    action_repeat: int

    @property
    def observation(self) -> ObservationConfig:
        """The egocentric observation the actor reads."""
        return ObservationConfig(lidar_rays=self.lidar_rays)

    def act(self, padded: np.ndarray) -> np.ndarray:
        """Deterministic actions ``(K, 2)`` in ``[-1, 1]`` of padded observations ``(K, D)``
        (the mean of the trained tanh-normal policy).

        Args:
            padded: ``(K, padded_size(lidar_rays))`` float32, ``pad_observations``' rows.
        Returns:
            ``(K, 2)`` float32 velocities as fractions of the defender's speed.
        """
        hidden = padded.astype(np.float32, copy=False)
        for weight, bias in self.layers:
            hidden = np.tanh(hidden @ weight + bias)
        return hidden


def padded_size(lidar_rays: int) -> int:
    """Entries of the padded layout with ``lidar_rays`` rays (module docstring)."""
    return 7 + lidar_rays + BLOCK * (MAX_DEFENDERS - 1 + MAX_ATTACKERS) + 1


def pad_observations(observations: np.ndarray, num_attackers: int, num_defenders: int,
                     lidar_rays: int) -> np.ndarray:
    """Defenders' egocentric observations in the padded layout (module docstring).

    Args:
        observations: ``(..., D)`` defenders' observations of a game of ``num_attackers``
            attackers and ``num_defenders`` defenders, with velocities and the time left.
        num_attackers, num_defenders: the game's player counts (at most ``MAX_ATTACKERS``,
            ``MAX_DEFENDERS``).
        lidar_rays: the observation's rays.
    Returns:
        ``(..., padded_size(lidar_rays))`` float32.
    """
    head = 7 + lidar_rays
    lead = observations.shape[:-1]
    out = np.zeros((*lead, padded_size(lidar_rays)), dtype=np.float32)
    out[..., :head] = observations[..., :head]
    out[..., -1] = observations[..., -1]
    regions = ((head, num_defenders - 1), (head + BLOCK * (MAX_DEFENDERS - 1), num_attackers))
    source = head
    for first, count in regions:
        blocks = observations[..., source:source + BLOCK * count].reshape(*lead, count, BLOCK)
        away = np.hypot(blocks[..., 0], blocks[..., 1]) + 4.0 * (blocks[..., 4] <= 0.5)
        order = np.argsort(away, axis=-1, kind="stable")[..., None]
        out[..., first:first + BLOCK * count] = np.take_along_axis(
            blocks, order, axis=-2).reshape(*lead, BLOCK * count)
        source += BLOCK * count
    return out


def check_players(scenario: Scenario) -> None:
    """``PolicyMismatch`` (one line, naming the scenario) when the padded layout cannot hold
    ``scenario``'s players."""
    if scenario.num_attackers > MAX_ATTACKERS or scenario.num_defenders > MAX_DEFENDERS:
        raise PolicyMismatch(
            f"defenders: learned-mappo plays up to {MAX_ATTACKERS} attackers and "
            f"{MAX_DEFENDERS} defenders; {scenario.name!r} has {scenario.num_attackers} "
            f"attackers and {scenario.num_defenders} defenders")


def save_weights(path: str | Path, weights: ActorWeights) -> None:
    """Write ``weights`` to ``path`` (``.npz``, atomically; module docstring)."""
    arrays: dict[str, np.ndarray] = {"meta": np.array(
        [FORMAT, weights.lidar_rays, weights.action_repeat], dtype=np.int64)}
    for index, (weight, bias) in enumerate(weights.layers):
        arrays[f"w{index}"] = np.asarray(weight, dtype=np.float32)
        arrays[f"b{index}"] = np.asarray(bias, dtype=np.float32)
    with atomic_write(path, "wb") as handle:
        np.savez_compressed(handle, **arrays)


def load_weights(path: str | Path | None = None) -> ActorWeights:
    """The actor saved at ``path`` (default: the shipped ``WEIGHTS``); a missing, damaged or
    foreign file is a ``ValueError`` naming it."""
    if path is None:
        source = resources.files("policies") / "weights" / WEIGHTS
        label = f"the shipped weights policies/weights/{WEIGHTS}"
    else:
        source, label = Path(path), f"weights {str(path)!r}"
    if not source.is_file():
        raise ValueError(f"defenders: {label} is not a file")
    try:
        with source.open("rb") as handle:
            with zipfile.ZipFile(handle) as archive:   # sizes as the zip's directory says
                expanded = sum(info.file_size for info in archive.infolist())
            handle.seek(0)
            if expanded <= MAX_WEIGHTS_BYTES:
                with np.load(handle, allow_pickle=False) as data:
                    arrays = {key: data[key] for key in data.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
        raise ValueError(f"defenders: {label} is not a readable .npz ({err})") from None
    if expanded > MAX_WEIGHTS_BYTES:
        raise ValueError(f"defenders: {label} expands to {expanded:,} bytes, more than an "
                         f"actor's {MAX_WEIGHTS_BYTES:,}; not loaded")
    return _checked(arrays, label)


def _checked(arrays: dict[str, np.ndarray], label: str) -> ActorWeights:
    def bad(why: str) -> ValueError:
        return ValueError(f"defenders: {label} is not a learned-mappo actor: {why}")

    meta = arrays.get("meta")
    if meta is None or meta.shape != (3,) or meta.dtype.kind != "i":
        raise bad("no meta [format, lidar_rays, action_repeat]")
    version, rays, repeat = (int(value) for value in meta)
    if version != FORMAT:
        raise bad(f"format {version}, this code reads {FORMAT}")
    if not 0 <= rays <= 360 or not 1 <= repeat <= 1000:
        raise bad(f"lidar_rays {rays}, action_repeat {repeat}")
    count = (len(arrays) - 1) // 2
    if count < 1 or set(arrays) != {"meta", *(f"{kind}{i}" for i in range(count)
                                              for kind in "wb")}:
        raise bad(f"arrays {sorted(arrays)}")
    layers, width = [], padded_size(rays)
    for index in range(count):
        weight, bias = arrays[f"w{index}"], arrays[f"b{index}"]
        if (weight.dtype != np.float32 or bias.dtype != np.float32 or weight.ndim != 2
                or weight.shape[0] != width or bias.shape != weight.shape[1:]):
            raise bad(f"layer {index} has shapes {weight.shape} / {bias.shape}, "
                      f"expected ({width}, n) / (n,) float32")
        if not (np.isfinite(weight).all() and np.isfinite(bias).all()):
            raise bad(f"layer {index} is not finite")
        layers.append((weight, bias))
        width = weight.shape[1]
    if width != 2:
        raise bad(f"{width} outputs, expected 2")
    return ActorWeights(tuple(layers), rays, repeat)


class LearnedMappoDefenders(ObservationPolicy):
    """The defenders of ``weights`` (an ``ActorWeights``): every defender's observation
    padded (``pad_observations``) and fed to the shared actor, its action held for the
    actor's ``action_repeat`` steps."""

    def __init__(self, weights: ActorWeights, label: str = "learned-mappo") -> None:
        super().__init__(self._predict, side="defenders",
                         action_repeat=weights.action_repeat, label=label,
                         observation=weights.observation)
        self.weights = weights
        self._players = (0, 0)

    def check(self, scenario: Scenario) -> None:
        check_players(scenario)

    def reset(self, scenario: Scenario) -> None:
        super().reset(scenario)
        self._players = (scenario.num_attackers, scenario.num_defenders)

    def _predict(self, batch: np.ndarray) -> np.ndarray:
        return self.weights.act(pad_observations(batch, *self._players,
                                                 self.weights.lidar_rays))


def learned_mappo(scenario: Scenario, weights: str | None = None) -> LearnedMappoDefenders:
    """The learned MAPPO defenders (``weights``: an ``.npz`` of ``save_weights``; default
    the shipped one), checked against ``scenario``'s players."""
    check_players(scenario)
    return LearnedMappoDefenders(load_weights(weights))
