"""Observations of the game: the one code path of ``ReachAvoidEnv`` (v0 and v1), the
vector env, and policies that act on observations (a trained network as a ``Policy``,
``policies.learned``).

Two layouts, chosen by ``ObservationConfig`` (``egocentric``). Every agent's observation
is a float32 vector in ``[-1, 1]`` of one size for all agents of a game; players are
numbered attackers first, then defenders (agent order); ``M``/``N`` attackers/defenders.

**Egocentric** (``ReachAvoid-v1``'s default) for an agent of side ``S`` (its teammates are
the other players of ``S``, its opponents the other side)::

    [own x, own y,                              position, normalised to the domain
     own vx, own vy,                            velocity, fraction of the fastest speed *
     target dx, target dy, target distance,     the target's nearest point minus the own
                                                position, and the signed distance to the
                                                target (negative inside), / diagonal
     lidar_0 .. lidar_{R-1},                    distance to the first wall or obstacle
                                                along ray r (world angle 2 pi r / R,
                                                counter-clockwise from +x), / lidar range
     for every teammate, then every opponent, in agent order:
         dx, dy, vx, vy, active,                relative position / diagonal, velocity
                                                (fraction of the fastest speed) *, flag
     time left]                                 1 - step / max_cycles *

``diagonal`` is the domain's diagonal (map units); the entries marked * are present only
when ``velocities`` / ``time_left`` are on; a velocity is the player's displacement over
the last step (walls included) divided by ``dt``, zero at reset and for players out of the
game. Size: ``7 + R + 5 (M + N - 1) + 1`` with every part on.

**Nearest players** (``teammates=T, opponents=O``): the blocks of the ``T`` nearest
teammates, then of the ``O`` nearest opponents, instead of every one in agent order: the
players in the game first, nearest first (ties in agent order), then those out of it
(nearest first), then zero blocks where a side has fewer. Size: ``7 + R + 5 (T + O) + 1``,
whatever ``M`` and ``N``: a policy trained on one team size plays another (one teammate
and one opponent are exactly an attacker's blocks in a 2 vs 1 game).

**Global** (``ReachAvoid-v0``, ``egocentric=False``): ``2 + 3 (M + N)``, positions
normalised to the domain (``-1`` at ``xmin``/``ymin``, ``+1`` at ``xmax``/``ymax``)::

    [own x, own y,
     attacker_0 x, attacker_0 y, attacker_0 active, ..., (every attacker)
     defender_0 x, defender_0 y, defender_0 active, ...] (every defender)

``active`` is 1.0 for a player still in the game (an attacker neither captured nor
arrived; a defender while some attacker is active), else 0.0; a player out of the game
keeps the position where it left.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from reachavoid_env import checks
from reachavoid_env.game_map import GameMap
from reachavoid_env.game_state import GameState
from reachavoid_env.lidar import Lidar, RayScene

MAX_RAYS = 360
MAX_NEAREST = 1024
"""The most nearest teammates or opponents an observation may hold."""


@dataclass(frozen=True)
class ObservationConfig:
    """What an observation holds (module docstring); checked once, here.

    ``egocentric``: the egocentric layout (``False``: v0's global vector; the other fields
    are then unused). ``lidar_rays``: rays per agent (0 to 360). ``lidar_range``: the
    longest distance a ray reports, map units (``None``: the domain's diagonal).
    ``velocities`` / ``time_left``: include the players' velocities / the time left.
    ``teammates`` / ``opponents``: observe that many nearest teammates / opponents (module
    docstring; both or neither; ``None``: every player, in agent order).
    """

    egocentric: bool = True
    lidar_rays: int = 16
    lidar_range: float | None = None
    velocities: bool = True
    time_left: bool = True
    teammates: int | None = None
    opponents: int | None = None

    def __post_init__(self) -> None:
        for name in ("egocentric", "velocities", "time_left"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"observation.{name}: expected true or false, got "
                                 f"{getattr(self, name)!r}")
        checks.integer(self.lidar_rays, "observation.lidar_rays", 0, MAX_RAYS)
        if self.lidar_range is not None:
            checks.positive(self.lidar_range, "observation.lidar_range")
        if (self.teammates is None) != (self.opponents is None):
            missing = "opponents" if self.opponents is None else "teammates"
            raise ValueError(f"observation.{missing}: set teammates and opponents together "
                             f"(every agent's observation has one size)")
        if self.teammates is not None:
            checks.integer(self.teammates, "observation.teammates", 0, MAX_NEAREST)
            checks.integer(self.opponents, "observation.opponents", 0, MAX_NEAREST)

    @property
    def nearest(self) -> bool:
        """Whether the observation holds the nearest players rather than every one."""
        return self.teammates is not None

    def size(self, num_attackers: int, num_defenders: int) -> int:
        """Entries of every agent's observation in a game of these player counts."""
        players = num_attackers + num_defenders
        if not self.egocentric:
            return 2 + 3 * players
        own = 4 if self.velocities else 2
        other = 5 if self.velocities else 3
        blocks = self.teammates + self.opponents if self.nearest else players - 1
        return own + 3 + self.lidar_rays + other * blocks + int(self.time_left)


GLOBAL = ObservationConfig(egocentric=False)
"""v0's observation: positions and active flags of every player, in absolute terms."""


class Normaliser(NamedTuple):
    """The affine map from map units to ``[-1, 1]`` per axis: ``(p - centre) / half``."""

    centre: np.ndarray   # (2,) map units
    half: np.ndarray     # (2,) half the domain's extent per axis, map units

    @classmethod
    def of(cls, game_map: GameMap) -> Normaliser:
        xmin, xmax, ymin, ymax = game_map.domain
        return cls(np.array([(xmin + xmax) / 2, (ymin + ymax) / 2]),
                   np.array([(xmax - xmin) / 2, (ymax - ymin) / 2]))


def player_table(positions: np.ndarray, active: np.ndarray,
                 normaliser: Normaliser) -> np.ndarray:
    """``(..., P, 3)`` float32: every player's normalised x, y (clipped to ``[-1, 1]``) and
    active flag.

    Args:
        positions: ``(..., P, 2)`` map units, attackers then defenders (``...``: copies).
        active: ``(..., P)`` bool.
        normaliser: the domain's ``Normaliser``.
    """
    table = np.empty((*active.shape, 3), dtype=np.float32)
    normalised = (positions - normaliser.centre) / normaliser.half
    table[..., :2] = np.minimum(np.maximum(normalised, -1.0, out=normalised), 1.0,
                                out=normalised)
    table[..., 2] = active
    return table


def agent_rows(table: np.ndarray, rows: slice | list[int]) -> np.ndarray:
    """``(..., L, 2 + 3 P)`` float32: the global observations of the players ``rows`` of
    ``table`` (``player_table``, ``(..., P, 3)``), one fresh array."""
    own = table[..., rows, :2]
    observations = np.empty((*own.shape[:-1], 2 + 3 * table.shape[-2]), dtype=np.float32)
    observations[..., :2] = own
    observations[..., 2:] = table.reshape(*table.shape[:-2], 1, -1)
    return observations


class Observer:
    """Every agent's observation of many copies of one game at once (one map, one
    ``ObservationConfig``; module docstring for the layouts).

    Args:
        config: what the observations hold.
        game_map: the map every copy plays.
        num_attackers, num_defenders: the player counts ``M``, ``N``.
        fastest: the largest player speed, map units per second (velocities' unit).
        max_cycles: the steps of an episode (the time left's unit).
    """

    def __init__(self, config: ObservationConfig, game_map: GameMap, num_attackers: int,
                 num_defenders: int, fastest: float, max_cycles: int) -> None:
        self.config = config
        self.size = config.size(num_attackers, num_defenders)
        self._sides = (num_attackers, num_defenders)
        self._full_size = dataclasses.replace(config, teammates=None, opponents=None).size(
            num_attackers, num_defenders)     # every player's block, before the nearest
        self.normaliser = Normaliser.of(game_map)
        self.target = game_map.target
        width, height = game_map.size
        self.diagonal = math.hypot(width, height)
        self.fastest = float(fastest)
        self.max_cycles = int(max_cycles)
        self.lidar = Lidar(RayScene.of(game_map), config.lidar_rays,
                           config.lidar_range or self.diagonal) \
            if config.egocentric and config.lidar_rays else None
        m, n = num_attackers, num_defenders
        attackers, defenders = list(range(m)), list(range(m, m + n))
        self.others = np.array([[k for k in attackers if k != i] + defenders for i in attackers]
                               + [[k for k in defenders if k != j] + attackers
                                  for j in defenders], dtype=np.intp).reshape(m + n, m + n - 1)

    def __call__(self, positions: np.ndarray, velocities: np.ndarray, active: np.ndarray,
                 steps: np.ndarray) -> np.ndarray:
        """Observations ``(K, P, size)`` float32 of ``K`` copies' ``P = M + N`` players.

        Args:
            positions: ``(K, P, 2)`` map units.
            velocities: ``(K, P, 2)`` map units per second.
            active: ``(K, P)`` bool.
            steps: ``(K,)`` steps played in each copy.
        """
        if not self.config.egocentric:
            return agent_rows(player_table(positions, active, self.normaliser), slice(None))
        return self._egocentric(positions, velocities, active, steps)

    def _egocentric(self, positions: np.ndarray, velocities: np.ndarray, active: np.ndarray,
                    steps: np.ndarray) -> np.ndarray:
        from reachavoid_env.lidar_kernel import egocentric

        config, (k, p) = self.config, active.shape
        if len(self.target) == 1:
            distance = self.target[0].signed_distance(positions)
            nearest = self.target[0].nearest_point(positions)
        else:
            distances = np.stack([shape.signed_distance(positions) for shape in self.target])
            closest = distances.argmin(axis=0)[None, ..., None]
            nearest = np.take_along_axis(
                np.stack([shape.nearest_point(positions) for shape in self.target]),
                closest, axis=0)[0]
            distance = distances.min(axis=0)
        time_left = 1.0 - np.asarray(steps, dtype=np.float64) / self.max_cycles
        lidar = self.lidar
        observations = np.empty((k, p, self._full_size), dtype=np.float32)
        egocentric(np.ascontiguousarray(positions, dtype=np.float64),
                   np.ascontiguousarray(velocities, dtype=np.float64), active, time_left,
                   nearest - positions, distance, self.others,
                   self.normaliser.centre, self.normaliser.half, self.diagonal,
                   self.fastest, config.velocities, config.time_left,
                   *(lidar.arrays() if lidar else _NO_LIDAR), observations)
        return self._nearest(observations) if config.nearest else observations

    def _nearest(self, full: np.ndarray) -> np.ndarray:
        """``(K, P, size)``: the observations ``full`` (every player's block, agent order)
        with the nearest teammates' and opponents' blocks instead (module docstring)."""
        config, (m, n) = self.config, self._sides
        width = 5 if config.velocities else 3
        start = (4 if config.velocities else 2) + 3 + config.lidar_rays
        end = start + width * (m + n - 1)
        blocks = full[..., start:end].reshape(*full.shape[:2], m + n - 1, width)
        out = np.empty((*full.shape[:2], self.size), dtype=np.float32)
        out[..., :start] = full[..., :start]
        out[..., self.size - (full.shape[-1] - end):] = full[..., end:]
        for rows, mates in ((slice(0, m), m - 1), (slice(m, m + n), n - 1)):
            chosen = [nearest_blocks(blocks[:, rows, :mates], config.teammates),
                      nearest_blocks(blocks[:, rows, mates:], config.opponents)]
            picked = np.concatenate(chosen, axis=2)
            out[:, rows, start:start + picked.shape[2] * width] = picked.reshape(
                *picked.shape[:2], -1)
        return out


def nearest_blocks(blocks: np.ndarray, count: int) -> np.ndarray:
    """``(K, L, count, w)``: of each row's blocks ``(K, L, G, w)`` (``dx, dy, ..., active``,
    the egocentric layout's), the ``count`` nearest: active ones first, then by distance
    ``hypot(dx, dy)`` (ties in the given order), zero blocks past ``G``."""
    out = np.zeros((*blocks.shape[:2], count, blocks.shape[3]), dtype=np.float32)
    if blocks.shape[2] and count:
        # |dx|, |dy| <= 1 (the diagonal's fraction), so 4 puts the inactive last
        key = np.hypot(blocks[..., 0], blocks[..., 1]) + 4.0 * (blocks[..., -1] < 0.5)
        order = np.argsort(key, axis=2, kind="stable")[..., :count]
        out[:, :, :order.shape[2]] = np.take_along_axis(blocks, order[..., None], axis=2)
    return out


_NO_LIDAR = (np.zeros((0, 2)), np.zeros((0, 4)), np.zeros((0, 0)), np.zeros((0, 3)), 1.0)


def observe(state: GameState, game_map: GameMap, config: ObservationConfig = GLOBAL,
            max_cycles: int | None = None) -> dict[str, np.ndarray]:
    """Every player's observation of ``state`` on ``game_map``, keyed by agent name
    (``attacker_0..M-1``, ``defender_0..N-1``): what ``ReachAvoidEnv`` with observation
    ``config`` (and ``max_cycles``, for the time left) returns for the same state, bit for
    bit. The velocities are ``state.velocities`` (zero where the state has none)."""
    attackers = state.active_attackers
    active = np.concatenate([attackers, np.full(len(state.defender_positions),
                                                attackers.any())])
    positions = np.concatenate([state.attacker_positions, state.defender_positions])
    names = state.attacker_names + state.defender_names
    if not config.egocentric:
        table = player_table(positions, active, Normaliser.of(game_map))
        return dict(zip(names, agent_rows(table, slice(None)), strict=True))
    if max_cycles is None:
        if config.time_left:
            raise ValueError("observe: max_cycles is needed for the time left")
        max_cycles = 1
    velocities = (state.velocities if state.velocities is not None
                  else np.zeros_like(positions))
    observer = Observer(config, game_map, len(attackers), len(state.defender_positions),
                        max(state.attacker_speed, state.defender_speed), max_cycles)
    rows = observer(positions[None], velocities[None], active[None], np.array([state.step]))
    return dict(zip(names, rows[0], strict=True))
