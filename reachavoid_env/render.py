"""pygame renderer of the game: an offscreen frame, an optional window, RGB arrays.

Map coordinates (map units, ``y`` up) are drawn onto a frame whose width and height are
multiples of 16 pixels (video encoders then keep the size). A frame reads from top to
bottom:

- the header: a title line (the scenario, the policies and the seed, as the caller
  gives it), the clock, and a policy's ``Overlay`` text lines;
- the map: domain, obstacles and target, attackers (red triangles, pointing where they
  head) and defenders (blue squares) with their capture discs, fading trails, a ``+``
  where an attacker was captured and a ring where one arrived, and the overlay's
  defender-attacker edges, each kind in its own style (``EDGE_STYLES``); names and text
  carry a white halo so that they stay readable over obstacles; on the last frame of an
  episode, a banner saying how it ended;
- the legend: every glyph, colour and line style of the map in words (the trails and how
  much time they cover included), with the counts of attackers in play, captured and
  arrived.

``Renderer`` draws the map's background here and stacks the layers of the modules beside
this one on it: ``render_frame`` (sizes, fonts and text without kerning, where the map
sits, the surface), ``render_players`` (trails and the players' glyphs),
``render_overlay`` (edges, header, banner) and ``render_legend``.

Colours come from ``reachavoid_env.palette``, shared with the tube figures.
"""

from __future__ import annotations

import os

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np  # noqa: E402
import pygame  # noqa: E402

from reachavoid_env import palette as P  # noqa: E402
from reachavoid_env.game_state import GameState  # noqa: E402
from reachavoid_env.overlay import Overlay  # noqa: E402
from reachavoid_env.render_frame import BLOCK, Frame  # noqa: E402
from reachavoid_env.render_legend import Legend  # noqa: E402
from reachavoid_env.render_overlay import EDGE_STYLES, Captions, Edges, EdgeStyle  # noqa: E402
from reachavoid_env.render_players import Players, Trails  # noqa: E402
from reachavoid_env.scenario import GameMap  # noqa: E402
from reachavoid_env.shapes import Shape  # noqa: E402

__all__ = ["EDGE_STYLES", "EdgeStyle", "Renderer"]


class Renderer:
    """Draws ``GameState`` snapshots of one map.

    ``width`` / ``height`` are the frame size in pixels, rounded up to multiples of 16;
    ``height`` defaults to the one that keeps the domain's aspect ratio between the
    header (the title, the clock and ``text_lines`` lines of overlay text) and the legend.
    ``trail_seconds`` is how much game time a trail covers before it has faded out.
    Drawing needs no display; ``show`` opens a window on first use.
    """

    def __init__(self, game_map: GameMap, capture_radius: float, width: int = 640,
                 height: int | None = None, *, trail_seconds: float = 1.0,
                 text_lines: int = 2) -> None:
        if width < BLOCK:
            raise ValueError(f"width: need at least {BLOCK} pixels, got {width}")
        if capture_radius <= 0:
            raise ValueError(f"capture_radius: must be positive, got {capture_radius}")
        if trail_seconds < 0:
            raise ValueError(f"trail_seconds: must be >= 0, got {trail_seconds}")
        if text_lines < 0:
            raise ValueError(f"text_lines: must be >= 0, got {text_lines}")
        self.game_map = game_map
        self.capture_radius = float(capture_radius)
        self.trail_seconds = float(trail_seconds)
        self.text_lines = int(text_lines)
        self.frame = Frame(game_map, width, self.text_lines)
        self.trails = Trails(self.frame, self.trail_seconds)
        self.players = Players(self.frame, self.capture_radius, self.trails)
        self.edges = Edges(self.frame)
        self.captions = Captions(self.frame)
        self.legend = Legend(self.frame, self.players, self.trails, self.edges)
        self.frame.place(self.legend.height, height)
        self.width, self.height = self.frame.width, self.frame.height
        self._background = self._draw_background()
        self._window: pygame.Surface | None = None
        self._clock = pygame.time.Clock()

    def to_pixels(self, points: np.ndarray) -> np.ndarray:
        """Map coordinates ``(..., 2)`` to frame pixels ``(..., 2)`` (float, ``y`` down)."""
        return self.frame.to_pixels(points)

    def _draw_background(self) -> pygame.Surface:
        """What every frame starts from: the map without players, and the legend's fixed
        parts."""
        frame = self.frame
        surface = frame.surface
        surface.fill(P.FRAME)
        field = frame.field()
        pygame.draw.rect(surface, P.FIELD, field)
        for shape in self.game_map.target:
            self._draw_shape(shape, P.TARGET, P.TARGET_EDGE)
        for shape in self.game_map.obstacles:
            self._draw_shape(shape, P.OBSTACLE, P.OBSTACLE)
        pygame.draw.rect(surface, P.BORDER, field.inflate(4, 4), width=2)
        rule = frame.legend_top - frame.margin // 2
        pygame.draw.line(surface, P.blend(P.FRAME, P.BORDER, 0.3), (frame.margin, rule),
                         (self.width - frame.margin, rule))
        self.legend.draw(None)
        return surface.copy()

    def _draw_shape(self, shape: Shape, fill: P.Color, edge: P.Color) -> None:
        points = [tuple(p) for p in self.to_pixels(shape.outline()).tolist()]
        pygame.draw.polygon(self.frame.surface, fill, points)
        pygame.draw.aalines(self.frame.surface, edge, True, points)
        pygame.draw.polygon(self.frame.surface, edge, points, width=2)

    def reset(self) -> None:
        """Forget trails (a new episode starts)."""
        self.trails.reset()

    def draw(self, state: GameState, overlay: Overlay | None = None, *, title: str = "",
             game_over: bool = False) -> None:
        """Render ``state`` (and ``overlay``) into the offscreen frame, under ``title``;
        ``game_over`` adds the banner saying how the episode ended.

        Successive calls are taken as one episode (trails grow) until ``reset`` or until
        the state's step goes backwards.
        """
        self.trails.update(state)
        self.frame.surface.blit(self._background, (0, 0))
        self.trails.draw_all(state.time)
        attackers = self.to_pixels(state.attacker_positions)
        defenders = self.to_pixels(state.defender_positions)
        self.players.draw_discs(defenders)
        if overlay is not None:
            self.edges.draw_all(overlay, state, attackers, defenders)
        self.players.draw(state, attackers, defenders)
        self.captions.draw_header(state, overlay, title)
        self.legend.draw(state)
        if game_over:
            self.captions.draw_banner(state)

    # -- output --------------------------------------------------------------------------

    def rgb_array(self) -> np.ndarray:
        """The last frame as a fresh ``(height, width, 3)`` uint8 array."""
        surface = self.frame.surface
        rows = np.frombuffer(surface.get_buffer(), dtype=np.uint8).reshape(
            self.height, surface.get_pitch())
        return rows[:, :3 * self.width].reshape(self.height, self.width, 3).copy()

    def show(self, fps: int) -> None:
        """Show the last frame in a window (opened on first use), at most ``fps`` per second."""
        if self._window is None:
            pygame.display.init()
            self._window = pygame.display.set_mode((self.width, self.height))
            pygame.display.set_caption("reachavoid")
        self._window.blit(self.frame.surface, (0, 0))
        pygame.event.pump()
        pygame.display.flip()
        self._clock.tick(fps)

    def close(self) -> None:
        """Close the window if one is open (the offscreen frame stays usable)."""
        if self._window is not None:
            pygame.display.quit()
            self._window = None
