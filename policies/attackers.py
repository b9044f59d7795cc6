"""Scripted attacker policies.

Each follows ``reachavoid_env.Policy``: ``reset(scenario)`` then ``act(state)``, which
returns a float32 ``(2,)`` action in ``[-1, 1]`` (a velocity as a fraction of the
attacker's speed) for every attacker still in the game.
"""

from __future__ import annotations

import numpy as np

from policies.tubes import tube_1v1, tube_2v1
from reachavoid_env import GameMap, GameState, Scenario
from reachavoid_env.geodesic import DEFAULT_CELLS, DistanceField, distance_field
from reachavoid_env.rules import unit_vectors
from solvers.hj import PAPER_GRIDS, ValueFunction


def target_centres(game_map: GameMap, samples: int = 41) -> np.ndarray:
    """One aim point per target shape, ``(K, 2)`` map units: its deepest interior point.

    The point is the sample of a ``samples`` x ``samples`` grid over the shape's bounds
    with the most negative signed distance: the centre of a box or circle, a point well
    inside a concave polygon (whose centroid may lie outside it).
    """
    centres = []
    for shape in game_map.target:
        x0, x1, y0, y1 = shape.bounds()
        grid = np.stack(np.meshgrid(np.linspace(x0, x1, samples), np.linspace(y0, y1, samples),
                                    indexing="ij"), axis=-1).reshape(-1, 2)
        centres.append(grid[np.argmin(shape.signed_distance(grid))])
    return np.asarray(centres)


class StraightAttacker:
    """Every attacker runs at full speed straight for the nearest target centre.

    It ignores obstacles (the physics makes it slide along them) and defenders.
    """

    def __init__(self) -> None:
        self._centres = np.zeros((0, 2))

    def reset(self, scenario: Scenario) -> None:
        self._centres = target_centres(scenario.map)

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        if len(self._centres) == 0:
            raise RuntimeError("StraightAttacker.act called before reset(scenario)")
        active = np.flatnonzero(state.active_attackers)
        positions = state.attacker_positions[active]
        gaps = self._centres[None, :, :] - positions[:, None, :]
        nearest = np.argmin(np.linalg.norm(gaps, axis=-1), axis=1)
        actions = unit_vectors(gaps[np.arange(len(active)), nearest]).astype(np.float32)
        return {f"attacker_{i}": actions[k] for k, i in enumerate(active)}


class RandomAttacker:
    """Every attacker runs at full speed in a random direction, redrawn every ``hold`` s.

    Directions are uniform on the circle, drawn from a generator seeded by ``seed`` at
    construction (a new episode continues the same stream).
    """

    def __init__(self, seed: int | None = None, hold: float = 0.25) -> None:
        if not hold > 0:
            raise ValueError(f"hold: must be positive seconds, got {hold}")
        self.hold = float(hold)
        self._rng = np.random.default_rng(seed)
        self._hold_steps = 0
        self._headings = np.zeros((0, 2), dtype=np.float32)
        self._drawn_at = 0

    def reset(self, scenario: Scenario) -> None:
        self._hold_steps = max(1, round(self.hold / scenario.dt))
        self._headings = np.zeros((0, 2), dtype=np.float32)

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        if self._hold_steps == 0:
            raise RuntimeError("RandomAttacker.act called before reset(scenario)")
        count = len(state.attacker_status)
        if len(self._headings) != count or state.step - self._drawn_at >= self._hold_steps \
                or state.step < self._drawn_at:
            angles = self._rng.uniform(0.0, 2.0 * np.pi, size=count)
            self._headings = np.stack([np.cos(angles), np.sin(angles)], axis=-1).astype(
                np.float32)
            self._drawn_at = state.step
        return {f"attacker_{i}": self._headings[i].copy()
                for i in np.flatnonzero(state.active_attackers)}


class HJAttacker:
    """Every attacker plays the 1 vs 1 optimal control against its most dangerous defender.

    The most dangerous defender of attacker ``i`` is the one with the largest 1 vs 1 value
    ``V11(a_i, d_j)`` (the one it is furthest from beating). The heading is
    ``-p_A / |p_A|`` of that game; where the gradient vanishes the attacker heads straight
    for the nearest target centre.
    """

    def __init__(self, vf11: ValueFunction) -> None:
        if vf11.game != "1v1":
            raise ValueError(f"vf11: expected a 1v1 value function, got {vf11.game!r}")
        self.vf11 = vf11
        self._straight = StraightAttacker()

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
                     progress: bool = True) -> HJAttacker:
        """Load (or solve and cache) the scenario's 1 vs 1 tube."""
        return cls(tube_1v1(scenario, grid1, progress))

    def reset(self, scenario: Scenario) -> None:
        self._straight.reset(scenario)

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        actions = self._straight.act(state)
        active = np.flatnonzero(state.active_attackers)
        if len(active) == 0:
            return actions
        attackers, defenders = state.attacker_positions[active], state.defender_positions
        m, n = len(active), len(defenders)
        states = np.concatenate([np.broadcast_to(attackers[:, None], (m, n, 2)),
                                 np.broadcast_to(defenders[None], (m, n, 2))], axis=-1)
        danger = np.argmax(self.vf11.value(states), axis=1)
        controls = self.vf11.attacker_control(states[np.arange(m), danger])
        for k, i in enumerate(active):
            if np.linalg.norm(controls[k]) > 0:
                actions[f"attacker_{i}"] = controls[k].astype(np.float32)
        return actions


class HJPairsAttacker:
    """Attackers that cannot win alone play the 2 vs 1 game in pairs; the others run the
    shortest path.

    Attacker ``i`` faces its most dangerous defender ``d`` (the largest 1 vs 1 value
    ``V11(a_i, d_j)``, as ``HJAttacker``). If it wins that game alone (``V11 <= 0``), or no
    other attacker in play loses its own, it runs the shortest path
    (``ShortestPathAttacker``). Otherwise it teams up with the partner ``j``, among those
    that lose alone, of the smallest 2 vs 1 value ``V21(a_i, a_j, d)`` and takes its own
    heading of that game, ``-p_{A1} / |p_{A1}|``:
    the pair splits so that ``d`` cannot stop both. It keeps doing so where the value says
    the pair loses: against defenders that err (a tube coarser than the attackers', a
    heuristic) that is where the extra arrivals come from. Other defenders are not in the
    pair's game; with one defender it is the 2 vs 1 game itself.
    """

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction,
                 cells: int = DEFAULT_CELLS) -> None:
        for name, vf, game in (("vf11", vf11, "1v1"), ("vf21", vf21, "2v1")):
            if vf.game != game:
                raise ValueError(f"{name}: expected a {game} value function, got {vf.game!r}")
        self.vf11, self.vf21 = vf11, vf21
        self._path = ShortestPathAttacker(cells)

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
                     grid2: int = PAPER_GRIDS.grid2, progress: bool = True) -> HJPairsAttacker:
        """Load (or solve and cache) the scenario's 1 vs 1 and 2 vs 1 tubes."""
        return cls(*tube_2v1(scenario, grid1, grid2, progress))

    def reset(self, scenario: Scenario) -> None:
        self._path.reset(scenario)

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        actions = self._path.act(state)
        active = np.flatnonzero(state.active_attackers)
        m, n = len(active), len(state.defender_positions)
        if m < 2:
            return actions
        attackers, defenders = state.attacker_positions[active], state.defender_positions
        duels = np.concatenate([np.broadcast_to(attackers[:, None], (m, n, 2)),
                                np.broadcast_to(defenders[None], (m, n, 2))], axis=-1)
        values = self.vf11.value(duels)
        danger = np.argmax(values, axis=1)
        lost = np.flatnonzero(values[np.arange(m), danger] > 0.0)
        if len(lost) < 2:
            return actions
        players, rivals, count = attackers[lost], defenders[danger[lost]], len(lost)
        games = np.concatenate([np.broadcast_to(players[:, None], (count, count, 2)),
                                np.broadcast_to(players[None], (count, count, 2)),
                                np.broadcast_to(rivals[:, None], (count, count, 2))],
                               axis=-1)          # games[i, j]: (a_i, a_j, d_i)
        pair_values = self.vf21.value(games)
        np.fill_diagonal(pair_values, np.inf)
        partner = np.argmin(pair_values, axis=1)
        controls = self.vf21.attacker_control(games[np.arange(count), partner], 0)
        for k, heading in zip(active[lost], controls, strict=True):
            if np.linalg.norm(heading) > 0:
                actions[f"attacker_{k}"] = heading.astype(np.float32)
        return actions


class ShortestPathAttacker:
    """Every attacker runs at full speed along the shortest path to the target around
    obstacles, ignoring defenders: the paper's scripted attacker.

    It descends the map's geodesic distance field (``reachavoid_env.geodesic``; obstacles grown
    by the scenario's player radius, ``cells`` grid cells along the longer side of the
    domain), sliding along walls and round their corners. Inside the target it stands
    still. ``field`` is the field in use (after ``reset``).
    """

    def __init__(self, cells: int = DEFAULT_CELLS) -> None:
        self.cells = cells
        self.field: DistanceField | None = None

    def reset(self, scenario: Scenario) -> None:
        self.field = distance_field(scenario.map, scenario.player_radius, self.cells)

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        if self.field is None:
            raise RuntimeError("ShortestPathAttacker.act called before reset(scenario)")
        active = np.flatnonzero(state.active_attackers)
        positions = state.attacker_positions[active]
        headings = self.field.descent(positions).astype(np.float32)
        headings[self.field.game_map.in_target(positions)] = 0.0
        return {f"attacker_{i}": headings[k] for k, i in enumerate(active)}
