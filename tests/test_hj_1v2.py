"""The 1 vs 2 solve (one attacker, two defenders): theory checks on small grids."""

from __future__ import annotations

import numpy as np
import pytest

from solvers.hj import SolverSettings, load_value_function, solve_1v2
from solvers.hj.geometry import free_distance
from solvers.hj.plot import scenario_panels, tube_figure

BAND = 0.02
"""Values within this of zero count as the boundary band (the tubes' numerical error)."""


@pytest.fixture(scope="module")
def vf12(paper_map, vf11):
    return solve_1v2(paper_map, vf11, grid_points=13, cache=False, progress=False)


def _node_tables(vf11, vf12):
    """At the 1 vs 2 grid's nodes: ``v12 (n, n, m)`` over (D1 node, D2 node, A node) and the
    1 vs 1 values ``v11 (n, m)`` of each defender node against each attacker node."""
    grid = vf12.grid
    n, m = grid.shape[0] * grid.shape[1], grid.shape[4] * grid.shape[5]
    attacker = grid.sub((4, 5)).mesh().reshape(1, m, 2)
    defender = grid.sub((0, 1)).mesh().reshape(n, 1, 2)
    pairs = np.concatenate(np.broadcast_arrays(attacker, defender), axis=-1)
    return vf12.full_values().reshape(n, n, m), vf11.value(pairs)


def test_one_defender_winning_alone_wins_with_a_partner(vf11, vf12):
    """Wherever either defender alone beats the attacker 1 vs 1 (away from the band), the
    pair beats it whatever the other defender's position; and pairs win somewhere that
    neither defender alone does."""
    assert vf12.solver["converged"] and vf12.axes == ("xD1", "yD1", "xD2", "yD2", "xA", "yA")
    v12, v11 = _node_tables(vf11, vf12)
    either = np.maximum(v11[:, None, :], v11[None, :, :])
    sure = either > BAND
    assert sure.sum() > 100_000
    assert np.mean(v12[sure] > 0) >= 0.99
    neither = (either < -BAND) & (v12 > BAND)
    assert neither.sum() > 100


def test_defenders_at_one_node_and_a_defender_in_an_obstacle(vf11, vf12, paper_map):
    """With both defenders at one node the pair is at least the lone defender; with one
    defender inside an obstacle the pair's outcome is the other defender's 1 vs 1."""
    v12, v11 = _node_tables(vf11, vf12)
    n = v11.shape[0]
    coincident = v12[np.arange(n), np.arange(n)]
    alone = v11 > BAND
    assert alone.sum() > 1000 and np.mean(coincident[alone] > 0) >= 0.99
    assert np.mean(coincident[v11 < -BAND] <= 0) < 1.0  # two at one node can do better
    inside = free_distance(paper_map, vf12.grid.sub((0, 1))).reshape(-1) < -1e-9
    assert inside.sum() > 0
    clear = np.abs(v11) > BAND
    outcome = v12[:, inside, :] > 0  # D2 in an obstacle
    expected = np.broadcast_to(v11[:, None, :] > 0, outcome.shape)
    mask = np.broadcast_to(clear[:, None, :], outcome.shape)
    assert np.mean(outcome[mask] == expected[mask]) >= 0.99


def test_exchange_symmetry(paper_map, vf11):
    """The stored half (one ordering of the defenders) answers both orderings exactly; a
    full solve agrees with it and is symmetric to the solver tolerance."""
    half = solve_1v2(paper_map, vf11, grid_points=9, cache=False, progress=False)
    full = solve_1v2(paper_map, vf11, grid_points=9, cache=False, progress=False,
                     settings=SolverSettings(exchange_symmetry=False))
    n = 9 * 9
    assert half.values.shape == (n * (n + 1) // 2, n) and full.values.shape == (9,) * 6
    swap = (2, 3, 0, 1, 4, 5)
    values = half.full_values()
    np.testing.assert_array_equal(values, values.transpose(swap))
    states = np.random.default_rng(3).uniform(-1, 1, (500, 6))
    swapped = states[:, list(swap)]
    np.testing.assert_allclose(half.value(states), half.value(swapped), atol=1e-6)
    np.testing.assert_allclose(half.control(states, "D1"), half.control(swapped, "D2"),
                               atol=1e-5)
    assert np.abs(full.values - full.values.transpose(swap)).max() < 1e-4
    assert np.mean((full.values <= 0) == (values <= 0)) > 0.999


def test_saved_value_file_and_slices(vf12, paper_map, tmp_path):
    loaded = load_value_function(vf12.save(tmp_path / "team.vf"), game_map=paper_map)
    assert loaded.game == "1v2" and loaded.symmetries == (("D1", "D2"),)
    states = np.random.default_rng(5).uniform(-1, 1, (50, 6))
    np.testing.assert_array_equal(loaded.value(states), vf12.value(states))
    panels = scenario_panels(loaded, [(0.2, 0.0)], [(0.5, -0.3), (0.4, 0.5)])
    assert [free for _, free, _ in panels] == ["A", "D1"]
    assert panels[1][2] == {"D2": (0.4, 0.5), "A": (0.2, 0.0)}
    tube_figure(panels, tmp_path / "team.png")
    assert (tmp_path / "team.png").stat().st_size > 0


def test_rejects_a_lower_value_of_another_game(paper_map, vf12):
    with pytest.raises(ValueError, match="1v1"):
        solve_1v2(paper_map, vf12, grid_points=9, cache=False, progress=False)
