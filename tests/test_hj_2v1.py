"""The 2 vs 1 reach-avoid solve: consistency with 1 vs 1, symmetry, the paper's example."""

from __future__ import annotations

import io

import imageio.v3 as iio
import numpy as np
import pytest

from reachavoid_env import builtin_map, palette
from solvers.hj import (
    InsufficientMemoryError,
    SolverSettings,
    load_value_function,
    solve_1v1,
    solve_2v1,
)
from solvers.hj.plot import tube_figure

PAPER_DEFENDER = (0.3, -0.3)
PAPER_ATTACKERS = ((-0.5, 0.0), (0.0, 0.8))


@pytest.fixture(scope="module")
def vf21(paper_map, vf11):
    return solve_2v1(paper_map, vf11, grid_points=15, cache=False, progress=False)


def _paper_states():
    (a1, a2), d = PAPER_ATTACKERS, PAPER_DEFENDER
    return np.array([[*a1, *d], [*a2, *d]]), np.array([[*a1, *a2, *d], [*a2, *a1, *d]])


def test_paper_example_at_coarse_grid(vf11, vf21):
    """Section IV-A: the defender at (0.3, -0.3) beats each attacker alone in 1 vs 1 and
    both together in 2 vs 1."""
    pairs, triple = _paper_states()
    assert np.all(vf11.value(pairs) > 0)
    assert np.all(vf21.value(triple) > 0)
    assert vf21.solver["converged"]


def test_one_attacker_winning_alone_wins_the_pair(vf11, vf21):
    """Where attacker 1 beats the defender in 1 vs 1, the 2 vs 1 state is an attacker-side
    win whatever attacker 2 does (and the same for attacker 2), away from the boundary."""
    grid = vf21.grid
    pair_grid = grid.sub((0, 1, 4, 5))
    na, m = grid.shape[0] * grid.shape[1], grid.shape[4] * grid.shape[5]
    v11 = vf11.value(pair_grid.mesh().reshape(-1, 4)).reshape(na, 1, m)
    points = grid.sub((0, 1)).mesh().reshape(na, 1, 1, 2)
    defender = grid.sub((4, 5)).mesh().reshape(1, 1, m, 2)
    gap = np.linalg.norm(points - defender, axis=-1)
    v21 = vf21.full_values().reshape(na, na, m)
    for swap in (False, True):
        alone, other = (v11, v11.transpose(1, 0, 2))
        second_gap = gap.transpose(1, 0, 2)
        if swap:
            alone, other, second_gap = other, alone, gap
        alone, other = np.broadcast_to(alone, v21.shape), np.broadcast_to(other, v21.shape)
        # away from the 1 vs 1 boundary band, and the other attacker not captured already
        # (that puts the state in the avoid set at once)
        sure = (alone < -0.02) & np.broadcast_to(
            second_gap > vf21.capture_radius + 2 * grid.spacing[0], v21.shape)
        assert sure.sum() > 10000 and np.any(other[sure] > 0)
        assert np.mean(v21[sure] <= 0) >= 0.99


def test_exchange_symmetry(paper_map, vf11):
    """The stored half (a1 >= a2) answers both orderings exactly and holds about half the
    values; a full solve without the symmetry shortcut agrees with it and is symmetric to
    the solver tolerance."""
    half = solve_2v1(paper_map, vf11, grid_points=11, cache=False, progress=False)
    full = solve_2v1(paper_map, vf11, grid_points=11, cache=False, progress=False,
                     settings=SolverSettings(exchange_symmetry=False))
    na = 11 * 11
    assert half.values.shape == (na * (na + 1) // 2, na) and full.values.shape == (11,) * 6
    swap = (2, 3, 0, 1, 4, 5)
    values = half.full_values()
    np.testing.assert_array_equal(values, values.transpose(swap))
    states = np.random.default_rng(4).uniform(-1, 1, (500, 6))
    swapped = states[:, [2, 3, 0, 1, 4, 5]]
    np.testing.assert_allclose(half.value(states), half.value(swapped), atol=1e-6)
    np.testing.assert_allclose(half.gradient(states)[:, [2, 3, 0, 1, 4, 5]],
                               half.gradient(swapped), atol=1e-5)
    assert np.abs(full.values - full.values.transpose(swap)).max() < 1e-4
    near = np.abs(full.values) < 0.02
    assert np.abs(full.values - values)[~near].max() < 0.02
    assert np.mean((full.values <= 0) == (values <= 0)) > 0.999


def test_jacobi_and_red_black_reach_the_same_fixed_point(paper_map, vf11):
    high = SolverSettings.with_accuracy("high")
    red_black = solve_2v1(paper_map, vf11, grid_points=9, settings=high, cache=False,
                          progress=False)
    jacobi = solve_2v1(paper_map, vf11, grid_points=9, cache=False, progress=False,
                       settings=high.replace(iteration="jacobi"))
    assert red_black.solver["converged"] and jacobi.solver["converged"]
    assert np.abs(red_black.full_values() - jacobi.full_values()).max() < 5e-3


def test_saved_6d_value_is_memory_mapped(vf21, tmp_path, paper_map):
    path = vf21.save(tmp_path / "pair.vf")
    loaded = load_value_function(path, game_map=paper_map)
    assert isinstance(loaded.values, np.memmap) and loaded.game == "2v1"
    assert loaded.axes == ("xA1", "yA1", "xA2", "yA2", "xD", "yD")
    states = np.random.default_rng(2).uniform(-1, 1, (100, 6))
    np.testing.assert_array_equal(loaded.value(states), vf21.value(states))
    heading = loaded.defender_control(states)
    norms = np.linalg.norm(heading, axis=1)
    assert np.all((np.abs(norms - 1) < 1e-9) | (norms == 0))
    assert loaded.attacker_control(states, attacker=1).shape == (100, 2)


def test_refuses_a_grid_that_does_not_fit(paper_map, vf11):
    with pytest.raises(InsufficientMemoryError, match="70x70x70x70x70x70"):
        solve_2v1(paper_map, vf11, grid_points=70, cache=False, progress=False)


def test_rejects_a_1v1_value_of_another_game(paper_map, vf21):
    with pytest.raises(ValueError, match="1v1"):
        solve_2v1(paper_map, vf21, grid_points=9, cache=False, progress=False)


def test_slice_figure(vf11, vf21, tmp_path):
    (a1, a2), d = PAPER_ATTACKERS, PAPER_DEFENDER
    path = tmp_path / "tubes.png"
    tube_figure([(vf11, "A", {"D": d}), (vf21, "A2", {"A1": a1, "D": d}),
                 (vf21, "D", {"A1": a1, "A2": a2})], path)
    assert path.stat().st_size > 10000
    with pytest.raises(ValueError, match="missing"):
        tube_figure([(vf21, "A2", {"D": d})])


def test_slice_figure_says_what_red_means_in_the_videos_colours(vf11):
    figure = tube_figure([(vf11, "A", {"D": PAPER_DEFENDER})])
    (legend,) = figure.legends
    words = [text.get_text() for text in legend.get_texts()]
    assert words[0] == "attackers win with the free player here (value <= 0)"
    assert {"target", "obstacle", "capture disc"} <= set(words)
    swatches = dict(zip(words, legend.legend_handles, strict=True))
    target_yellow = pytest.approx(palette.unit(palette.TARGET))
    assert swatches["target"].get_facecolor()[:3] == target_yellow
    (ax,) = figure.axes
    target = [p for p in ax.patches if p.get_facecolor()[:3] == target_yellow]
    assert len(target) == 1  # the map's target, in the videos' yellow
    png = io.BytesIO()
    figure.savefig(png, format="png", dpi=60)
    pixels = iio.imread(png.getvalue(), extension=".png")[..., :3].reshape(-1, 3).astype(int)
    red = np.all(np.abs(pixels - palette.ATTACKER_WINS) <= 3, axis=1)
    assert red.sum() > 1000  # the shaded region is the legend's colour


@pytest.mark.slow
def test_paper_example_at_paper_resolution():
    """At the paper's grids, 45^4 and 30^6 (solved into the test session's throwaway cache:
    about 3.5 minutes on 2 quiet cores, 10 when shared)."""
    game_map = builtin_map("paper")
    pair = solve_1v1(game_map, grid_points=45)
    triple = solve_2v1(game_map, pair, grid_points=30)
    pairs, states = _paper_states()
    assert np.all(pair.value(pairs) > 0)
    assert np.all(triple.value(states) > 0)
