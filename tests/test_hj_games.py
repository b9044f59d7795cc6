"""Games declared outside ``solvers/`` solve with no change to the solver; warm starts."""

from __future__ import annotations

import numpy as np
import pytest

from reachavoid_env import Circle, GameMap, builtin_map
from solvers.hj import (
    Game,
    Grid,
    SolverSettings,
    attacker,
    defender,
    distance,
    maximum,
    solve_1v1,
    solve_2v1,
    solve_declared,
)
from solvers.open_space import segment_distance

VA, VD, R, EDGE = 1.0, 1.5, 0.05, -0.8


def edge_race(speeds=(VA, VD), radius=R) -> Game:
    """A toy game: the attacker wins by reaching the strip ``x <= EDGE`` uncaptured (a
    target from the node coordinates, not the map); captured: lost."""
    a, d = attacker("A", speeds[0]), defender("D", speeds[1])
    gap = radius - distance(a, d)
    return Game("edge_race", (a, d), target=maximum(a.x - EDGE, gap), avoid=gap,
                parameters={"capture_radius": radius})


def test_a_game_declared_in_a_test_solves_and_agrees_with_theory():
    """Attacker sure: running straight left, it reaches the strip before the defender can
    come within the capture radius of its path. Defender sure: the Apollonius disc (capture
    radius 0) stays right of the strip. Margins of two cells through Lipschitz bounds."""
    game_map = GameMap((-1.0, 1.0, -1.0, 1.0), (Circle((0.9, 0.9), 0.05),))  # unused
    grid = Grid.for_players(game_map.domain, 2, 25)
    vf = solve_declared(edge_race(), game_map, grid, cache=False, progress=False)
    assert vf.game == "edge_race" and vf.axes == ("xA", "yA", "xD", "yD")
    assert vf.solver["converged"]
    h = grid.spacing[0]
    rng = np.random.default_rng(0)
    a = rng.uniform(-0.7, 0.9, (20000, 2))
    d = rng.uniform(-0.9, 0.9, (20000, 2))
    goal = np.stack([np.full(len(a), EDGE), a[:, 1]], axis=1)
    slack = (segment_distance(d, a, goal) - R) / VD - (a[:, 0] - EDGE) / VA
    k = VA / VD
    centre = (a - k * k * d) / (1 - k * k)
    radius = k * np.linalg.norm(a - d, axis=1) / (1 - k * k)
    clearance = centre[:, 0] - radius - EDGE
    attacker_sure = slack > 2 * h * (1 / VA + 1 / VD)
    defender_sure = clearance > 2 * h * (1 + k) / (1 - k) + R / (1 - k)
    assert attacker_sure.sum() > 1000 and defender_sure.sum() > 1000
    value = vf.value(np.concatenate([a, d], axis=1))
    assert np.mean(value[attacker_sure] <= 0) >= 0.99
    assert np.mean(value[defender_sure] > 0) >= 0.99
    heading = vf.control(np.array([[0.5, 0.0, 0.9, 0.9]]), "A")
    assert heading[0, 0] < -0.8  # away from the strip's edge, the attacker runs left


def _start_margin(fine, coarse, margin):
    """Smallest (coarse value + margin - fine value) over the fine nodes."""
    nodes = fine.grid.mesh().reshape(-1, fine.grid.ndim)
    return float(np.min(coarse.value(nodes) + margin - fine.full_values().reshape(-1)))


@pytest.mark.parametrize("game", ["1v1", "2v1"])
def test_warm_start_agrees_with_cold(game):
    """Warm (from the coarse grid plus the margin) and cold solves reach the same fixed
    point: the start was above the cold value at every node, signs agree on >= 99.9% of the
    nodes and values within the tolerance's reach."""
    game_map = builtin_map("paper")
    high = SolverSettings.with_accuracy("high")
    warm_settings = high.replace(warm_start=True, warm_from=6)
    if game == "1v1":
        n, solve = 21, lambda s, n: solve_1v1(game_map, grid_points=n, settings=s, cache=False,
                                              progress=False)
    else:
        vf11 = solve_1v1(game_map, grid_points=21, cache=False, progress=False)
        n, solve = 11, lambda s, n: solve_2v1(game_map, vf11, grid_points=n, settings=s,
                                              cache=False, progress=False)
    cold, warm = solve(high, n), solve(warm_settings, n)
    assert warm.solver["warm_start"] == [(n + 1) // 2] * cold.grid.ndim
    assert cold.solver["converged"] and warm.solver["converged"]
    coarse = solve(high, (n + 1) // 2)
    assert _start_margin(cold, coarse, warm_settings.warm_margin) >= 0.0
    cold_values, warm_values = cold.full_values(), warm.full_values()
    assert np.mean((cold_values <= 0) == (warm_values <= 0)) >= 0.999
    assert np.abs(cold_values - warm_values).max() < 2e-3


def test_a_grid_that_misses_the_target_is_refused(tmp_path, cache_in_tmp, capsys):
    """A 0.2-wide target on a +-100 map falls between the nodes of a 15-node grid: the tube
    would say the defender wins everywhere (nobody can arrive), so no tube is solved."""
    from reachavoid.cli import main
    from reachavoid_env import Box, GameMap
    from solvers.hj import check_tubes_memory, solve_1v1

    wide = GameMap((-100.0, 100.0, -100.0, 100.0), (Box((30.1, 30.1), (30.3, 30.3)),))
    with pytest.raises(ValueError, match="no free grid node lies in the target"):
        solve_1v1(wide, grid_points=15, progress=False)
    with pytest.raises(ValueError, match="on the 1v1 grid"):
        check_tubes_memory(wide, (1.0, 1.5), 0.1, 15, 7)
    scenario = tmp_path / "wide.toml"
    scenario.write_text('name = "wide"\n[map]\ndomain = [-100.0, 100.0, -100.0, 100.0]\n'
                        'target = { type = "box", min = [30.1, 30.1], max = [30.3, 30.3] }\n'
                        '[players]\nattackers = [[-50.0, 0.0]]\ndefenders = [[30.0, -30.0]]\n')
    assert main(["solve", "--scenario", str(scenario), "--game", "1v1", "--grid", "15"]) == 2
    assert "no free grid node lies in the target" in capsys.readouterr().err
    assert not list((tmp_path / "cache").glob("*.vf"))
