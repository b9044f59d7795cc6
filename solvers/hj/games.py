"""The paper's games (Section III B-C) and the 1 vs 2 game as declarations, and their solves.

"Captured", "in the target" and "in an obstacle" are the rules of
``reachavoid_env/rules.py`` written as level sets (``tests/test_rules_in_games.py`` checks
the sets against the rules node by node); ``R`` is the capture radius.

1 vs 1, eq. (RA_11), axes ``(xA, yA, xD, yD)``:
- target ``R11``: the attacker is in the target and not captured, or the defender is in an
  obstacle: ``l = min(max(sT(a), R - |a - d|), sF(d))``;
- avoid ``A11``: captured, or the attacker is in an obstacle: ``g = max(R - |a - d|, -sF(a))``;
with ``sT`` the target's signed distance and ``sF`` the free-space signed distance
(``geometry``). The attacker wins where the value is <= 0.

2 vs 1, eqs. (RA_21) and (L), axes ``(xA1, yA1, xA2, yA2, xD, yD)``:
- target ``R21``: either attacker in the target uncaptured, or the defender in an obstacle:
  ``l = min(reach(a1, d), reach(a2, d), sF(d))`` with ``reach = max(sT(a), R - |a - d|)``;
- avoid ``A21 = L1 u L2``: one attacker is captured or in an obstacle and the other loses
  its remaining 1 vs 1 game: ``g = max(min(lost(a1, d), V11(a2, d)),
  min(lost(a2, d), V11(a1, d)))`` with ``lost = max(R - |a - d|, -sF(a))`` and ``V11`` the
  converged 1 vs 1 value (same speeds and radius), interpolated onto the 2 vs 1 grid once.
The attackers may be exchanged. The attacker side (at least one attacker arrives) wins
where the value is <= 0.

1 vs 2 (beyond the paper, its named next step), axes ``(xD1, yD1, xD2, yD2, xA, yA)``:
the attacker ``A`` wins by reaching the target uncaptured by either defender. The rules
(``reachavoid_env/rules.py``): an attacker is captured when *some* defender is within
the capture radius (``within_capture``, ``distance <= R``), it arrives when its position
is in the target, and a tie goes to capture (``resolve_events``). Hence
- target ``R12``: ``A`` in the target and captured by neither defender, or one defender
  in an obstacle while ``A`` beats the other in their 1 vs 1 game:
  ``l = min(max(sT(a), R - |a - d1|, R - |a - d2|), max(sF(d1), V11(a, d2)),
  max(sF(d2), V11(a, d1)))``;
- avoid ``A12``: ``A`` captured by either defender or in an obstacle, or one defender in
  an obstacle while the other beats ``A`` 1 vs 1: ``g = max(R - |a - d1|, R - |a - d2|,
  -sF(a), min(-sF(d1), V11(a, d2)), min(-sF(d2), V11(a, d1)))``.
A defender in an obstacle (a state play never reaches: players cannot enter obstacles)
leaves the game, as in 1 vs 1, but here that does not hand the attacker the win while the
other defender still stops it: the state is decided by the remaining 1 vs 1 game (target
where the attacker beats the other defender, avoid where it does not; both defenders in
obstacles: the attacker wins, as ``V11 <= 0`` where its defender is in one). Capture by
a defender wins over everything (the avoid set takes priority in the update, and the rules
give ties to capture), so a defender on an obstacle's edge still captures. With the
defenders at one node the game is at least the 1 vs 1 game: either defender alone may
play the 1 vs 1 optimal control.
The defenders may be exchanged; they lead the axes so that the stored half holds one
ordering of them (``layout``: the last player's plane is a row, symmetry acts across
rows), as the attackers do in 2 vs 1.
"""

from __future__ import annotations

from collections.abc import Sequence

from reachavoid_env import GameMap
from solvers.hj.game import Game, Player, attacker, defender, distance, maximum, minimum, table
from solvers.hj.grid import Grid
from solvers.hj.marcher import check_target_seen
from solvers.hj.reach_avoid import check_memory
from solvers.hj.settings import PAPER_GRIDS, SolverSettings
from solvers.hj.solve import solve_declared
from solvers.hj.value import ValueFunction


def _reach(a: Player, d: Player, radius: float):
    """<= 0: ``a`` is in the target and not captured by ``d``."""
    return maximum(a.target, radius - distance(a, d))


def _lost(a: Player, d: Player, radius: float):
    """> 0: ``a`` is captured by ``d`` or in an obstacle."""
    return maximum(radius - distance(a, d), -a.free)


def game_1v1(speeds: tuple[float, float], capture_radius: float) -> Game:
    """Eq. (RA_11): one attacker ``A`` against one defender ``D``."""
    a, d = attacker("A", speeds[0]), defender("D", speeds[1])
    return Game("1v1", (a, d), target=minimum(_reach(a, d, capture_radius), d.free),
                avoid=_lost(a, d, capture_radius),
                parameters={"capture_radius": capture_radius})


def game_2v1(speeds: tuple[float, float], capture_radius: float) -> Game:
    """Eqs. (RA_21), (L): attackers ``A1``, ``A2`` against ``D``; reads the 1 vs 1 value
    as the table ``value_1v1`` over (attacker, defender)."""
    a1, a2, d = attacker("A1", speeds[0]), attacker("A2", speeds[0]), defender("D", speeds[1])
    target = minimum(_reach(a1, d, capture_radius), _reach(a2, d, capture_radius), d.free)
    avoid = maximum(minimum(_lost(a1, d, capture_radius), table("value_1v1", a2, d)),
                    minimum(_lost(a2, d, capture_radius), table("value_1v1", a1, d)))
    return Game("2v1", (a1, a2, d), target=target, avoid=avoid, symmetries=(("A1", "A2"),),
                parameters={"capture_radius": capture_radius})


def game_1v2(speeds: tuple[float, float], capture_radius: float) -> Game:
    """Attacker ``A`` against defenders ``D1``, ``D2`` (module docstring); reads the 1 vs 1
    value as the table ``value_1v1`` over (attacker, defender)."""
    d1, d2, a = defender("D1", speeds[1]), defender("D2", speeds[1]), attacker("A", speeds[0])
    gap1, gap2 = capture_radius - distance(a, d1), capture_radius - distance(a, d2)
    target = minimum(maximum(a.target, gap1, gap2),
                     maximum(d1.free, table("value_1v1", a, d2)),
                     maximum(d2.free, table("value_1v1", a, d1)))
    avoid = maximum(gap1, gap2, -a.free,
                    minimum(-d1.free, table("value_1v1", a, d2)),
                    minimum(-d2.free, table("value_1v1", a, d1)))
    return Game("1v2", (d1, d2, a), target=target, avoid=avoid, symmetries=(("D1", "D2"),),
                parameters={"capture_radius": capture_radius})


def _checked_speeds(speeds: Sequence[float], capture_radius: float) -> tuple[float, float]:
    speeds = (float(speeds[0]), float(speeds[1]))
    if min(speeds) <= 0 or capture_radius <= 0:
        raise ValueError(f"speeds {speeds} and capture_radius {capture_radius} must be positive")
    return speeds


def _check_lower(vf11: ValueFunction, game_map: GameMap) -> None:
    if vf11.game != "1v1":
        raise ValueError(f"vf11: expected a 1v1 value function, got {vf11.game}")
    if vf11.game_map != game_map:
        raise ValueError("vf11: solved on another map than game_map")


def check_tube_grids(game_map: GameMap, grid1: int, grid2: int | None = None) -> None:
    """``ScenarioError`` when the 1 vs 1 grid of ``grid1`` nodes per axis, or the 2 vs 1 and
    1 vs 2 grid of ``grid2``, has no free node in ``game_map``'s target
    (``check_target_seen``): what ``validate`` checks of the tubes."""
    for label, points in (("1v1", grid1), ("2v1 and 1v2", grid2)):
        if points is not None:
            check_target_seen(game_map, Grid.for_players(game_map.domain, 1, points), label)


def check_tubes_memory(game_map: GameMap, speeds: tuple[float, float], capture_radius: float,
                       grid1: int, grid2: int | None = None,
                       settings: SolverSettings | None = None) -> None:
    """Raise ``InsufficientMemoryError`` before any solve when the 1 vs 1 game on ``grid1``
    nodes per axis, or (with ``grid2``) the 2 vs 1 or 1 vs 2 game on ``grid2``, would not
    fit in memory, and ``ValueError`` when its grid has no free node in the target
    (``check_target_seen``): a command checks every tube it may solve before solving any."""
    speeds = _checked_speeds(speeds, capture_radius)
    settings = settings or SolverSettings()
    games = [(game_1v1(speeds, capture_radius), 2, grid1)]
    if grid2 is not None:
        games += [(game_2v1(speeds, capture_radius), 3, grid2),
                  (game_1v2(speeds, capture_radius), 3, grid2)]
    check_tube_grids(game_map, grid1, grid2)
    for game, players, points in games:
        check_memory(game, Grid.for_players(game_map.domain, players, points), settings,
                     f"{game.name} HJ solve")


def solve_1v1(game_map: GameMap, speeds: tuple[float, float] = (1.0, 1.5),
              capture_radius: float = 0.1,
              grid_points: int | Sequence[int] = PAPER_GRIDS.grid1,
              settings: SolverSettings | None = None, cache: bool = True,
              progress: bool = True) -> ValueFunction:
    """Solve the 1 vs 1 game on ``game_map``; ``speeds = (attacker, defender)``.

    ``grid_points``: nodes per axis over the map's domain. With ``cache`` the result is
    looked up in, or stored to, the on-disk cache (``cache`` module).
    """
    speeds = _checked_speeds(speeds, capture_radius)
    game = game_1v1(speeds, float(capture_radius))
    grid = Grid.for_players(game_map.domain, 2, grid_points)
    return solve_declared(game, game_map, grid, settings, cache=cache, progress=progress)


def solve_2v1(game_map: GameMap, vf11: ValueFunction,
              grid_points: int | Sequence[int] = PAPER_GRIDS.grid2,
              settings: SolverSettings | None = None, cache: bool = True,
              progress: bool = True) -> ValueFunction:
    """Solve the 2 vs 1 game on ``game_map`` with the avoid set built from ``vf11``.

    Speeds and capture radius are those of ``vf11`` (a 1 vs 1 solve on the same map).
    The result is memory-mapped from its file when cached.
    """
    _check_lower(vf11, game_map)
    game = game_2v1((vf11.attacker_speed, vf11.defender_speed), vf11.capture_radius)
    grid = Grid.for_players(game_map.domain, 3, grid_points)
    return solve_declared(game, game_map, grid, settings, cache=cache, progress=progress,
                          lower={"value_1v1": vf11})


def solve_1v2(game_map: GameMap, vf11: ValueFunction,
              grid_points: int | Sequence[int] = PAPER_GRIDS.grid2,
              settings: SolverSettings | None = None, cache: bool = True,
              progress: bool = True) -> ValueFunction:
    """Solve the 1 vs 2 game on ``game_map`` with target and avoid sets built from ``vf11``.

    Speeds and capture radius are those of ``vf11`` (a 1 vs 1 solve on the same map). Axes
    ``(xD1, yD1, xD2, yD2, xA, yA)``; the stored half holds one ordering of the defenders.
    """
    _check_lower(vf11, game_map)
    game = game_1v2((vf11.attacker_speed, vf11.defender_speed), vf11.capture_radius)
    grid = Grid.for_players(game_map.domain, 3, grid_points)
    return solve_declared(game, game_map, grid, settings, cache=cache, progress=progress,
                          lower={"value_1v1": vf11})
