"""Renderer: frame size and type, headless drawing, what is drawn where, human mode."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pygame
import pytest

import reachavoid_env
from reachavoid_env import (
    AttackerStatus,
    Box,
    Circle,
    GameMap,
    GameState,
    Overlay,
    Polygon,
    builtin_scenario,
    merged_overlay,
)
from reachavoid_env import palette as R
from reachavoid_env.environment import _live_part
from reachavoid_env.overlay import Edge, EdgeKind, outcome_line
from reachavoid_env.render import EDGE_STYLES, Renderer

ACTIVE, CAPTURED, ARRIVED = AttackerStatus.ACTIVE, AttackerStatus.CAPTURED, AttackerStatus.ARRIVED


def state_of(attackers, defenders, status=None, time=0.0, step=0) -> GameState:
    attackers = np.asarray(attackers, dtype=float)
    return GameState(time=time, step=step, attacker_positions=attackers,
                     defender_positions=np.asarray(defenders, dtype=float),
                     attacker_status=tuple(status or [ACTIVE] * len(attackers)),
                     attacker_speed=1.0, defender_speed=1.5, capture_radius=0.1)


@pytest.fixture
def scenario():
    return builtin_scenario("paper_6v2")


@pytest.fixture
def renderer(scenario):
    return Renderer(scenario.map, scenario.capture_radius)


def pixel(renderer: Renderer, frame: np.ndarray, point) -> np.ndarray:
    x, y = renderer.to_pixels(np.asarray(point, dtype=float))
    return frame[int(round(y)), int(round(x))].astype(int)


def is_like(color, reference, tolerance=30) -> bool:
    return bool(np.all(np.abs(np.asarray(color) - np.asarray(reference)) <= tolerance))


@pytest.mark.parametrize(("width", "height", "expected_width"), [
    (640, None, 640),
    (500, None, 512),
    (320, 250, 320),
])
def test_frame_is_uint8_rgb_with_sides_multiple_of_16(scenario, width, height, expected_width):
    renderer = Renderer(scenario.map, scenario.capture_radius, width=width, height=height)
    renderer.draw(state_of(scenario.attackers, scenario.defenders))
    frame = renderer.rgb_array()
    assert frame.dtype == np.uint8
    assert frame.shape[1:] == (expected_width, 3)
    assert frame.shape[0] % 16 == 0 and frame.shape[1] % 16 == 0
    if height is None:  # the square domain between the header and the legend
        assert expected_width < frame.shape[0] < expected_width * 1.3
    else:
        assert frame.shape[0] == 256
    assert frame.flags.writeable


def test_domain_keeps_its_aspect_ratio():
    wide = GameMap(domain=(0.0, 4.0, 0.0, 1.0), target=(Box((3.5, 0.4), (3.8, 0.6)),))
    renderer = Renderer(wide, 0.1, width=640)
    (x0, y0), (x1, y1) = renderer.to_pixels(np.array([[0.0, 1.0], [4.0, 0.0]]))
    assert (x1 - x0) / (y1 - y0) == pytest.approx(4.0)
    assert renderer.height < 400  # the header and the legend, and a flat map


def test_rgb_array_is_a_fresh_copy(renderer, scenario):
    renderer.draw(state_of(scenario.attackers, scenario.defenders))
    first = renderer.rgb_array()
    first[:] = 0
    assert renderer.rgb_array().any()


def test_players_target_and_obstacles_in_their_colours(renderer, scenario):
    renderer.draw(state_of(scenario.attackers, scenario.defenders))
    frame = renderer.rgb_array()
    for point in scenario.attackers:
        assert is_like(pixel(renderer, frame, point), R.ATTACKER)
    for point in scenario.defenders:
        assert is_like(pixel(renderer, frame, point), R.DEFENDER)
    assert is_like(pixel(renderer, frame, (0.0, -0.65)), R.OBSTACLE, 0)
    assert is_like(pixel(renderer, frame, (0.0, 0.45)), R.OBSTACLE, 0)
    assert is_like(pixel(renderer, frame, (0.72, 0.25)), R.TARGET, 0)
    assert is_like(pixel(renderer, frame, (-0.6, 0.6)), R.FIELD, 0)
    # inside a capture disc but away from the defender glyph: tinted blue
    disc = pixel(renderer, frame, (0.3 - 0.07, 0.5))
    assert disc[2] > disc[0] + 20 and not is_like(disc, R.DEFENDER)


def test_circle_and_concave_polygon_obstacles():
    notch = Polygon(((-0.8, -0.8), (0.0, -0.8), (0.0, 0.0), (-0.4, -0.4), (-0.8, 0.0)))
    game_map = GameMap(domain=(-1.0, 1.0, -1.0, 1.0), target=(Circle((0.7, 0.7), 0.1),),
                       obstacles=(Circle((0.5, -0.5), 0.2), notch))
    renderer = Renderer(game_map, 0.1)
    renderer.draw(state_of([[0.9, -0.9]], [[-0.9, 0.9]]))
    frame = renderer.rgb_array()
    assert is_like(pixel(renderer, frame, (0.5, -0.5)), R.OBSTACLE, 0)
    assert is_like(pixel(renderer, frame, (0.5, -0.25)), R.FIELD, 0)
    assert is_like(pixel(renderer, frame, (-0.4, -0.6)), R.OBSTACLE, 0)
    assert is_like(pixel(renderer, frame, (-0.7, -0.1)), R.OBSTACLE, 0)
    assert is_like(pixel(renderer, frame, (-0.4, -0.2)), R.FIELD, 0)  # in the notch
    assert is_like(pixel(renderer, frame, (0.7, 0.7)), R.TARGET, 0)


def test_overlay_edge_is_drawn_green(renderer):
    attacker, defender = np.array([-0.6, 0.6]), np.array([-0.6, -0.1])
    state = state_of([attacker], [defender])
    middle = (attacker + defender) / 2
    renderer.draw(state)
    plain = pixel(renderer, renderer.rgb_array(), middle)
    renderer.reset()
    renderer.draw(state, Overlay(edges=(("defender_0", "attacker_0"),)))
    edged = pixel(renderer, renderer.rgb_array(), middle)
    assert is_like(plain, R.FIELD, 0)
    assert is_like(edged, R.EDGE, 40)
    renderer.draw(state_of([attacker], [defender], [CAPTURED]),
                  Overlay(edges=(("defender_0", "attacker_0"),)))
    assert is_like(pixel(renderer, renderer.rgb_array(), middle), R.FIELD, 0)  # left the game


def test_overlay_with_unknown_names_is_an_error(renderer):
    state = state_of([[-0.6, 0.6]], [[-0.6, -0.1]])
    with pytest.raises(ValueError, match="defender_3"):
        renderer.draw(state, Overlay(edges=(("defender_3", "attacker_0"),)))
    with pytest.raises(ValueError, match="attacker_9"):
        renderer.draw(state, Overlay(edges=(("defender_0", "attacker_9"),)))


def test_captured_plus_and_arrival_ring(renderer):
    captured, arrived = np.array([-0.5, 0.5]), np.array([0.7, 0.2])
    renderer.draw(state_of([captured, arrived], [[-0.5, -0.8]], [CAPTURED, ARRIVED]))
    frame = renderer.rgb_array()
    assert is_like(pixel(renderer, frame, captured), R.CAPTURED, 10)
    # the '+' has arms but no diagonal
    scale = renderer.width / 640 * 5 / renderer.frame.scale
    assert is_like(pixel(renderer, frame, captured + [scale, 0]), R.CAPTURED, 10)
    assert is_like(pixel(renderer, frame, captured + [scale, scale]), R.FIELD, 10)
    assert is_like(pixel(renderer, frame, arrived), R.ATTACKER, 30)  # centre dot
    ring = 7 * 1.3 * renderer.width / 640 / renderer.frame.scale
    assert is_like(pixel(renderer, frame, arrived + [ring, 0]), R.ATTACKER, 60)
    assert is_like(pixel(renderer, frame, arrived + [ring / 2, 0]), R.TARGET, 10)


def test_trails_follow_players_and_reset_clears_them(renderer):
    path = np.linspace([-0.8, 0.8], [-0.2, 0.8], 61)
    for step, point in enumerate(path):
        renderer.draw(state_of([point], [[0.5, -0.8]], time=step * 0.005, step=step))
    frame = renderer.rgb_array()
    behind = pixel(renderer, frame, path[30])
    assert not is_like(behind, R.FIELD, 5) and behind[0] > behind[2] + 30  # pale red
    renderer.reset()
    renderer.draw(state_of([path[-1]], [[0.5, -0.8]], time=0.3, step=60))
    assert is_like(pixel(renderer, renderer.rgb_array(), path[30]), R.FIELD, 0)


def test_trail_fades_out_after_trail_seconds(scenario):
    renderer = Renderer(scenario.map, 0.1, trail_seconds=0.1)
    path = np.linspace([-0.8, 0.8], [-0.2, 0.8], 61)
    for step, point in enumerate(path):
        renderer.draw(state_of([point], [[0.5, -0.8]], time=step * 0.005, step=step))
    frame = renderer.rgb_array()
    assert is_like(pixel(renderer, frame, path[10]), R.FIELD, 0)  # 0.25 s old: gone
    assert not is_like(pixel(renderer, frame, path[55]), R.FIELD, 5)


def test_a_new_episode_starts_without_old_trails(renderer):
    path = np.linspace([-0.8, 0.8], [-0.2, 0.8], 41)
    for step, point in enumerate(path):
        renderer.draw(state_of([point], [[0.5, -0.8]], time=step * 0.005, step=step))
    renderer.draw(state_of([[-0.8, -0.2]], [[0.5, -0.8]], time=0.0, step=0))
    assert is_like(pixel(renderer, renderer.rgb_array(), path[20]), R.FIELD, 0)


def test_header_shows_time_counts_and_overlay_lines(renderer, scenario):
    header = slice(0, renderer.frame.header)
    renderer.draw(state_of(scenario.attackers, scenario.defenders))
    first = renderer.rgb_array()[header]
    renderer.draw(state_of(scenario.attackers, scenario.defenders, time=0.5, step=100))
    later = renderer.rgb_array()[header]
    renderer.draw(state_of(scenario.attackers, scenario.defenders, time=0.5, step=100),
                  Overlay(lines=("assignment: D0 -> A1",)))
    with_line = renderer.rgb_array()[header]
    assert (first != later).any()
    assert (later != with_line).any()
    assert (first.max(axis=2) < 100).sum() > 100  # dark text on the light header


def test_no_text_lines_leave_the_overlay_text_out(scenario):
    renderer = Renderer(scenario.map, scenario.capture_radius, text_lines=0)
    state = state_of(scenario.attackers, scenario.defenders)
    renderer.draw(state)
    plain = renderer.rgb_array()
    renderer.draw(state, Overlay(lines=("assignment: D0 -> A1",)))  # raised IndexError
    assert (renderer.rgb_array() == plain).all()


def test_bad_arguments(scenario):
    with pytest.raises(ValueError, match="capture_radius"):
        Renderer(scenario.map, 0.0)
    with pytest.raises(ValueError, match="width"):
        Renderer(scenario.map, 0.1, width=8)
    with pytest.raises(ValueError, match="height"):
        Renderer(scenario.map, 0.1, height=16)


def test_human_mode_opens_a_window_headless(monkeypatch, renderer, scenario):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    renderer.draw(state_of(scenario.attackers, scenario.defenders))
    renderer.show(fps=1000)
    window = pygame.display.get_surface()
    assert window is not None and window.get_size() == (renderer.width, renderer.height)
    shown = np.frombuffer(pygame.image.tobytes(window, "RGB"), dtype=np.uint8)
    assert (shown.reshape(renderer.height, renderer.width, 3) == renderer.rgb_array()).all()
    renderer.show(fps=1000)
    renderer.close()
    assert not pygame.display.get_init()


def test_env_human_mode_under_the_dummy_driver(monkeypatch):
    import reachavoid_env

    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    env = reachavoid_env.parallel_env(scenario="paper_2v1", render_mode="human")
    env.reset(seed=0)
    env.step({agent: np.ones(2, dtype=np.float32) for agent in env.agents})
    assert env.render() is None
    assert pygame.display.get_surface() is not None
    env.close()
    assert not pygame.display.get_init()


def test_long_overlay_lines_are_cut_short(renderer, scenario):
    line = "assignment: " + ", ".join(f"defender_{j}->attacker_{j}" for j in range(12))
    fitted = renderer.frame.fit(line, renderer.width - 20)
    assert fitted.endswith("...") and line.startswith(fitted[:-3])
    assert renderer.frame.font.size(fitted)[0] <= renderer.width - 20
    assert renderer.frame.fit("short", renderer.width) == "short"
    renderer.draw(state_of(scenario.attackers, scenario.defenders), Overlay(lines=(line,)))


def test_overlay_text_stays_to_the_last_frame_and_edges_leave_with_their_attacker():
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    env.reset(seed=0)
    overlay = Overlay(edges=(("defender_0", "attacker_0"), ("defender_0", "attacker_1")),
                      lines=("MIP: 2 guaranteed",), kinds=(EdgeKind.PAIR, EdgeKind.PAIR))
    state = env.unwrapped.game_state()
    assert _live_part(overlay, state) == overlay
    left = replace(state, attacker_status=(AttackerStatus.CAPTURED, AttackerStatus.ACTIVE))
    assert _live_part(overlay, left).kinded_edges == (
        Edge("defender_0", "attacker_1", EdgeKind.PAIR),)
    over = replace(state, attacker_status=(AttackerStatus.CAPTURED, AttackerStatus.ARRIVED))
    assert _live_part(overlay, over) == Overlay(lines=("MIP: 2 guaranteed",))


def test_overlay_kinds_one_per_edge_and_merged():
    edges = (("defender_0", "attacker_0"), ("defender_0", "attacker_1"))
    with pytest.raises(ValueError, match="kinds: expected one per edge"):
        Overlay(edges=edges, kinds=(EdgeKind.PAIR,))
    assert Overlay(edges=edges, kinds=("assign", "assign")) == Overlay(edges=edges)
    assert Overlay(edges=edges, kinds=("pair", "pair")).kinds == (EdgeKind.PAIR,) * 2

    class Draws:
        def __init__(self, overlay):
            self._overlay = overlay

        def overlay(self):
            return self._overlay

    merged = merged_overlay(Draws(Overlay(edges=edges[:1])),
                            Draws(Overlay(edges=edges[1:], kinds=(EdgeKind.TEAM,))))
    assert [e.kind for e in merged.kinded_edges] == [EdgeKind.ASSIGN, EdgeKind.TEAM]


@pytest.mark.parametrize("kind", list(EdgeKind))
def test_each_edge_kind_in_its_own_colour(renderer, kind):
    attacker, defender = np.array([-0.6, 0.6]), np.array([-0.6, -0.1])
    state = state_of([attacker], [defender])
    renderer.draw(state, Overlay(edges=(("defender_0", "attacker_0"),), kinds=(kind,)))
    frame = renderer.rgb_array()
    (xa, ya), (xd, yd) = renderer.to_pixels(np.array([attacker, defender]))
    column = frame[round(ya) + 20:round(yd) - 20, round(xa)].astype(int)  # along the edge
    colour = np.asarray(EDGE_STYLES[kind].color)
    drawn = np.all(np.abs(column - colour) <= 40, axis=1)
    others = [np.asarray(s.color) for k, s in EDGE_STYLES.items() if k is not kind]
    assert drawn.any()
    assert not any(np.all(np.abs(column - c) <= 40, axis=1).any() for c in others)
    if EDGE_STYLES[kind].gap:  # dashed: field shows between the dashes
        assert not drawn.all()
    else:
        assert drawn.mean() > 0.9


def test_legend_shows_every_kind_and_the_counts(renderer, scenario):
    legend = slice(renderer.frame.legend_top, renderer.height)
    status = [ACTIVE] * 4 + [CAPTURED, ARRIVED]
    renderer.draw(state_of(scenario.attackers, scenario.defenders, status))
    frame = renderer.rgb_array()
    below = frame[legend].reshape(-1, 3).astype(int)
    for colour in (R.TARGET, R.OBSTACLE, R.ATTACKER, R.DEFENDER, R.CAPTURED,
                   *(s.color for s in EDGE_STYLES.values())):
        assert np.all(np.abs(below - colour) <= 20, axis=1).sum() > 5, colour
    renderer.draw(state_of(scenario.attackers, scenario.defenders))
    assert (renderer.rgb_array()[legend] != frame[legend]).any()  # the counts changed
    map_rows = slice(renderer.frame.header, renderer.frame.legend_top)
    assert (renderer.rgb_array()[map_rows] == frame[map_rows]).sum() > 0.99 * frame[
        map_rows].size - 2000  # only the attackers' glyphs differ


def test_legend_names_the_trails_when_there_are_any(scenario):
    words = [entry.widest for group in Renderer(scenario.map, 0.1).legend.groups for entry in group]
    assert "trails: the last 1 s" in words
    still = Renderer(scenario.map, 0.1, trail_seconds=0.0)
    assert not any(e.widest.startswith("trails") for group in still.legend.groups for e in group)


@pytest.mark.parametrize("word", ["attackers", "guaranteed"])
def test_words_keep_their_letters_together(scenario, word):
    """The bundled font's kerning opened gaps inside words ("at tackers", "guaran teed"):
    at a 1280-pixel frame no blank run between two letters is wider than 4 pixels (those
    were 5 and 6)."""
    font = Renderer(scenario.map, 0.1, width=1280).frame.font
    ink = (pygame.surfarray.array_alpha(font.render(word, True, R.TEXT)) > 60).any(axis=1)
    columns = np.flatnonzero(ink)
    runs = np.diff(columns) - 1
    assert runs.max() <= 4, runs


def test_labels_have_a_halo_over_obstacles(renderer):
    inside = np.array([0.0, -0.65])  # in the lower obstacle
    renderer.draw(state_of([inside], [[-0.8, 0.8]]))
    frame = renderer.rgb_array()
    x, y = renderer.to_pixels(inside)
    box = frame[round(y) - 25:round(y), round(x):round(x) + 30].reshape(-1, 3).astype(int)
    assert np.all(box == R.HALO, axis=1).sum() > 20  # white around the letters
    assert np.all(np.abs(box - R.ATTACKER) <= 30, axis=1).sum() > 5  # the red "A0"


def test_title_and_outcome_banner(renderer, scenario):
    state = state_of(scenario.attackers, scenario.defenders, [CAPTURED] * 5 + [ARRIVED])
    renderer.draw(state)
    plain = renderer.rgb_array()
    renderer.draw(state, title="paper_6v2: hj defenders vs shortest-path attackers, seed 0")
    titled = renderer.rgb_array()
    renderer.draw(state, game_over=True)
    banner = renderer.rgb_array()
    title_rows = slice(0, renderer.frame.title_font.get_linesize())
    assert (titled[title_rows] != plain[title_rows]).any()
    assert (titled[renderer.frame.header:] == plain[renderer.frame.header:]).all()
    top = renderer.to_pixels(np.array([0.0, 0.95]))[1]
    band = slice(renderer.frame.header, round(top) + 20)
    assert (banner[band] != plain[band]).sum() > 1000
    assert np.all(np.abs(banner[band].reshape(-1, 3).astype(int) - R.ATTACKER) <= 20,
                  axis=1).sum() > 50  # red frame: an attacker arrived
    assert outcome_line(6, 5, 1) == "6 attackers: 5 captured, 1 reached the target"
    assert outcome_line(6, 6, 0) == "All 6 attackers captured"
    assert outcome_line(6, 3, 1).endswith("2 held off (time up)")
