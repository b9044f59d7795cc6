"""pygame renderer of the game: an offscreen frame, an optional window, RGB arrays.

Map coordinates (map units, ``y`` up) are drawn onto a frame whose width and height are
multiples of 16 pixels (video encoders then keep the size). The frame shows the domain,
obstacles and target, attackers (red triangles, pointing where they head) and defenders
(blue squares) with their capture discs, fading trails, a ``+`` where an attacker was
captured and a ring where one arrived, the clock and counts, and a policy's ``Overlay``
(defender-attacker edges in green as in the paper's figures, skipped once the
attacker has left the game; extra text lines).
"""

from __future__ import annotations

import math
import os
from collections import deque

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np  # noqa: E402
import pygame  # noqa: E402

from reachavoid_env.game_state import AttackerStatus, GameState, Overlay  # noqa: E402
from reachavoid_env.scenario import GameMap  # noqa: E402
from reachavoid_env.shapes import Shape  # noqa: E402

Color = tuple[int, int, int]

FRAME: Color = (226, 229, 234)
FIELD: Color = (255, 255, 255)
BORDER: Color = (60, 64, 72)
OBSTACLE: Color = (92, 96, 106)
TARGET: Color = (252, 222, 128)
TARGET_EDGE: Color = (196, 150, 30)
ATTACKER: Color = (214, 39, 40)
DEFENDER: Color = (31, 90, 200)
EDGE: Color = (20, 170, 60)
CAPTURED: Color = (40, 40, 40)
TEXT: Color = (30, 32, 38)
TEXT_DIM: Color = (80, 86, 98)

BLOCK = 16  # frame sizes are multiples of this (H.264 macroblocks)


def _round_up(pixels: float) -> int:
    return max(BLOCK, int(math.ceil(pixels / BLOCK)) * BLOCK)


def _rgb_surface(width: int, height: int) -> pygame.Surface:
    """A 24-bit surface whose bytes are R, G, B per pixel: ``rgb_array`` is one copy."""
    return pygame.Surface((width, height), 0, 24, (0xFF, 0xFF00, 0xFF0000, 0))


def _blend(color: Color, toward: Color, amount: float) -> Color:
    """``color`` moved ``amount`` (0..1) of the way to ``toward``."""
    return tuple(round(c + (t - c) * amount) for c, t in zip(color, toward, strict=True))


class Renderer:
    """Draws ``GameState`` snapshots of one map.

    ``width`` / ``height`` are the frame size in pixels, rounded up to multiples of 16;
    ``height`` defaults to the one that keeps the domain's aspect ratio below the header
    (the clock, the counts next to the glyphs they count, and ``text_lines`` lines of
    overlay text).
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
        pygame.font.init()
        self.game_map = game_map
        self.capture_radius = float(capture_radius)
        self.trail_seconds = float(trail_seconds)
        self.text_lines = int(text_lines)
        self.width = _round_up(width)
        unit = self.width / 640  # sizes below are tuned for a 640-pixel frame
        self._font = pygame.font.Font(None, max(10, round(22 * unit)))
        self._label_font = pygame.font.Font(None, max(8, round(17 * unit)))
        self._line_height = self._font.get_linesize()
        self._header = round(self._line_height * (1 + self.text_lines) + 10 * unit)
        self._margin = max(4, round(10 * unit))
        self._glyph = max(3.0, 7.0 * unit)
        self._trail_width = max(1, round(3 * unit))
        self._edge_width = max(1, round(3 * unit))

        domain_w, domain_h = game_map.size
        scale = (self.width - 2 * self._margin) / domain_w
        if height is None:
            self.height = _round_up(self._header + 2 * self._margin + domain_h * scale)
        else:
            self.height = _round_up(height)
            scale = min(scale, (self.height - self._header - 2 * self._margin) / domain_h)
            if scale <= 0:
                raise ValueError(f"height: {height} pixels leave no room for the map")
        self._scale = scale
        free_x = self.width - domain_w * scale
        free_y = self.height - self._header - domain_h * scale
        self._origin = (free_x / 2, self._header + free_y / 2)

        self._surface = _rgb_surface(self.width, self.height)
        self._background = self._draw_background()
        self._disc = self._draw_disc()
        self._labels: dict[str, pygame.Surface] = {}
        self._fitted: dict[str, str] = {}
        self._window: pygame.Surface | None = None
        self._clock = pygame.time.Clock()
        self._trails: dict[str, deque[tuple[float, float, float]]] = {}
        self._last: GameState | None = None

    # -- coordinates ---------------------------------------------------------------------

    def to_pixels(self, points: np.ndarray) -> np.ndarray:
        """Map coordinates ``(..., 2)`` to frame pixels ``(..., 2)`` (float, ``y`` down)."""
        p = np.asarray(points, dtype=np.float64)
        xmin, _, _, ymax = self.game_map.domain
        x = self._origin[0] + (p[..., 0] - xmin) * self._scale
        y = self._origin[1] + (ymax - p[..., 1]) * self._scale
        return np.stack([x, y], axis=-1)

    def _pixel(self, point: np.ndarray | tuple[float, float]) -> tuple[float, float]:
        x, y = self.to_pixels(np.asarray(point))
        return (float(x), float(y))

    # -- static layers -------------------------------------------------------------------

    def _draw_shape(self, surface: pygame.Surface, shape: Shape, fill: Color,
                    edge: Color) -> None:
        points = [tuple(p) for p in self.to_pixels(shape.outline()).tolist()]
        pygame.draw.polygon(surface, fill, points)
        pygame.draw.aalines(surface, edge, True, points)
        pygame.draw.polygon(surface, edge, points, width=2)

    def _draw_background(self) -> pygame.Surface:
        surface = _rgb_surface(self.width, self.height)
        surface.fill(FRAME)
        xmin, xmax, ymin, ymax = self.game_map.domain
        (left, top), (right, bottom) = self._pixel((xmin, ymax)), self._pixel((xmax, ymin))
        field = pygame.Rect(round(left), round(top), round(right - left), round(bottom - top))
        pygame.draw.rect(surface, FIELD, field)
        for shape in self.game_map.target:
            self._draw_shape(surface, shape, TARGET, TARGET_EDGE)
        for shape in self.game_map.obstacles:
            self._draw_shape(surface, shape, OBSTACLE, OBSTACLE)
        pygame.draw.rect(surface, BORDER, field.inflate(4, 4), width=2)
        return surface

    def _draw_disc(self) -> pygame.Surface:
        radius = self.capture_radius * self._scale
        size = int(math.ceil(2 * radius)) + 4
        disc = pygame.Surface((size, size), pygame.SRCALPHA)
        center = (size / 2, size / 2)
        pygame.draw.aacircle(disc, (*DEFENDER, 38), center, radius)
        pygame.draw.aacircle(disc, (*DEFENDER, 150), center, radius, width=1)
        return disc

    # -- episode memory ------------------------------------------------------------------

    def reset(self) -> None:
        """Forget trails (a new episode starts)."""
        self._trails.clear()
        self._last = None

    def _update_trails(self, state: GameState) -> None:
        last = self._last
        if last is not None and (state.step < last.step or state.time < last.time
                                 or len(state.attacker_status) != len(last.attacker_status)
                                 or len(state.defender_positions)
                                 != len(last.defender_positions)):
            self.reset()
        names = state.attacker_names + state.defender_names
        pixels = self.to_pixels(np.concatenate([state.attacker_positions,
                                                state.defender_positions]))
        spacing = 2.0  # pixels between stored trail points
        for name, (x, y) in zip(names, pixels.tolist(), strict=True):
            trail = self._trails.setdefault(name, deque())
            if not trail or math.hypot(x - trail[-1][1], y - trail[-1][2]) >= spacing:
                trail.append((state.time, x, y))
            horizon = state.time - self.trail_seconds
            while len(trail) > 1 and trail[0][0] < horizon:
                trail.popleft()
        self._last = state

    # -- drawing -------------------------------------------------------------------------

    def draw(self, state: GameState, overlay: Overlay | None = None) -> None:
        """Render ``state`` (and ``overlay``) into the offscreen frame.

        Successive calls are taken as one episode (trails grow) until ``reset`` or until
        the state's step goes backwards.
        """
        self._update_trails(state)
        surface = self._surface
        surface.blit(self._background, (0, 0))
        for name, trail in self._trails.items():
            color = ATTACKER if name.startswith("attacker") else DEFENDER
            self._draw_trail(trail, state.time, color)
        attackers = self.to_pixels(state.attacker_positions)
        defenders = self.to_pixels(state.defender_positions)
        half = self._disc.get_width() / 2
        for x, y in defenders.tolist():
            surface.blit(self._disc, (round(x - half), round(y - half)))
        if overlay is not None:
            self._draw_edges(overlay, state, attackers, defenders)
        for i, (status, (x, y)) in enumerate(zip(state.attacker_status, attackers.tolist(),
                                                 strict=True)):
            if status is AttackerStatus.ACTIVE:
                self._draw_attacker(f"attacker_{i}", x, y)
            elif status is AttackerStatus.CAPTURED:
                self._draw_plus(x, y)
            else:
                self._draw_arrival(x, y)
            self._draw_label(f"A{i}", x, y, ATTACKER if status is AttackerStatus.ACTIVE
                             else _blend(ATTACKER, FIELD, 0.45))
        for j, (x, y) in enumerate(defenders.tolist()):
            self._draw_square(x, y)
            self._draw_label(f"D{j}", x, y, DEFENDER)
        self._draw_text(state, overlay)

    def _draw_trail(self, trail: deque[tuple[float, float, float]], now: float,
                    color: Color) -> None:
        if len(trail) < 2 or self.trail_seconds == 0:
            return
        bands = 6
        points = list(trail)
        # Split the trail into `bands` runs by age; older runs are paler.
        start = 0
        for band in range(bands, 0, -1):
            newest = now - self.trail_seconds * (band - 1) / bands
            end = start
            while end < len(points) and points[end][0] <= newest:
                end += 1
            run = points[max(0, start - 1):end]
            if len(run) >= 2:
                shade = _blend(color, FIELD, 0.35 + 0.6 * (band - 1) / bands)
                pixels = [(p[1], p[2]) for p in run]
                if self._trail_width > 1:
                    pygame.draw.lines(self._surface, shade, False, pixels, self._trail_width - 1)
                pygame.draw.aalines(self._surface, shade, False, pixels)
            start = end

    def _draw_attacker(self, name: str, x: float, y: float) -> None:
        trail = self._trails.get(name)
        if trail is None or len(trail) < 2:
            self._draw_triangle(x, y)  # upward until the attacker has moved
            return
        (_, x0, y0), (_, x1, y1) = trail[-2], trail[-1]
        self._draw_triangle(x, y, math.atan2(y0 - y1, x1 - x0))

    def _draw_triangle(self, x: float, y: float, heading: float = math.pi / 2) -> None:
        """An attacker glyph at pixel ``(x, y)`` pointing at ``heading`` (radians, y up)."""
        g = self._glyph * 1.25
        corners = [(x + g * math.cos(heading + turn), y - g * math.sin(heading + turn))
                   for turn in (0.0, 2.4, -2.4)]
        pygame.draw.polygon(self._surface, ATTACKER, corners)
        pygame.draw.aalines(self._surface, _blend(ATTACKER, (0, 0, 0), 0.4), True, corners)

    def _draw_square(self, x: float, y: float) -> None:
        side = round(2 * self._glyph * 0.85)
        square = pygame.Rect(0, 0, side, side)
        square.center = (round(x), round(y))
        pygame.draw.rect(self._surface, DEFENDER, square)
        pygame.draw.rect(self._surface, _blend(DEFENDER, (0, 0, 0), 0.4), square, width=1)

    def _draw_plus(self, x: float, y: float) -> None:
        g, w = self._glyph, max(2, round(self._glyph / 3))
        pygame.draw.line(self._surface, CAPTURED, (x - g, y), (x + g, y), w)
        pygame.draw.line(self._surface, CAPTURED, (x, y - g), (x, y + g), w)

    def _draw_arrival(self, x: float, y: float) -> None:
        g = self._glyph
        pygame.draw.aacircle(self._surface, ATTACKER, (x, y), g * 1.3, width=max(2, round(g / 3)))
        pygame.draw.aacircle(self._surface, ATTACKER, (x, y), g * 0.4)

    def _draw_label(self, text: str, x: float, y: float, color: Color) -> None:
        key = f"{text}{color}"
        label = self._labels.get(key)
        if label is None:
            label = self._label_font.render(text, True, color)
            self._labels[key] = label
        offset = self._glyph * 1.3
        self._surface.blit(label, (round(x + offset), round(y - offset - label.get_height() / 2)))

    def _draw_edges(self, overlay: Overlay, state: GameState, attackers: np.ndarray,
                    defenders: np.ndarray) -> None:
        attacker_index = {n: i for i, n in enumerate(state.attacker_names)}
        defender_index = {n: j for j, n in enumerate(state.defender_names)}
        for defender, attacker in overlay.edges:
            if defender not in defender_index:
                raise ValueError(f"overlay edge ({defender!r}, {attacker!r}): unknown defender "
                                 f"{defender!r}")
            if attacker not in attacker_index:
                raise ValueError(f"overlay edge ({defender!r}, {attacker!r}): unknown attacker "
                                 f"{attacker!r}")
            i = attacker_index[attacker]
            if state.attacker_status[i] is not AttackerStatus.ACTIVE:
                continue  # the attacker has left the game: nothing to assign
            start, end = defenders[defender_index[defender]].tolist(), attackers[i].tolist()
            pygame.draw.aaline(self._surface, EDGE, start, end, self._edge_width)

    def _draw_text(self, state: GameState, overlay: Overlay | None) -> None:
        """Header: the clock, then the counts behind the glyphs they count (a legend)."""
        pad, top = self._margin, 5
        clock = self._font.render(f"t = {state.time:.3f} s   step {state.step}", True, TEXT)
        self._surface.blit(clock, (pad, top))
        total = len(state.attacker_status)
        captured, arrived = len(state.captured), len(state.arrived)
        counts = ((self._draw_triangle, f"active {total - captured - arrived} / {total}"),
                  (self._draw_plus, f"captured {captured}"),
                  (self._draw_arrival, f"arrived {arrived}"))
        x = self.width - pad
        middle = top + self._line_height / 2
        for glyph, words in reversed(counts):
            text = self._font.render(words, True, TEXT)
            x -= text.get_width()
            self._surface.blit(text, (x, top))
            x -= self._glyph * 2.2
            glyph(x, middle)
            x -= self._glyph * 4
        lines = list(overlay.lines) if overlay is not None else []
        if len(lines) > self.text_lines:
            lines = lines[:self.text_lines]
            lines[-1] += " ..."
        for k, line in enumerate(lines, start=1):
            text = self._font.render(self._fit(line, self.width - 2 * pad), True, TEXT_DIM)
            self._surface.blit(text, (pad, top + k * self._line_height))

    def _fit(self, line: str, pixels: int) -> str:
        """``line``, cut short with "..." if it is wider than ``pixels`` (remembered)."""
        fitted = self._fitted.get(line)
        if fitted is None:
            fitted, cut = line, len(line)
            if self._font.size(line)[0] > pixels:
                while cut > 0 and self._font.size(line[:cut] + "...")[0] > pixels:
                    cut -= 1
                fitted = line[:cut] + "..."
            if len(self._fitted) > 256:  # lines that change every frame
                self._fitted.clear()
            self._fitted[line] = fitted
        return fitted

    # -- output --------------------------------------------------------------------------

    def rgb_array(self) -> np.ndarray:
        """The last frame as a fresh ``(height, width, 3)`` uint8 array."""
        rows = np.frombuffer(self._surface.get_buffer(), dtype=np.uint8).reshape(
            self.height, self._surface.get_pitch())
        return rows[:, :3 * self.width].reshape(self.height, self.width, 3).copy()

    def show(self, fps: int) -> None:
        """Show the last frame in a window (opened on first use), at most ``fps`` per second."""
        if self._window is None:
            pygame.display.init()
            self._window = pygame.display.set_mode((self.width, self.height))
            pygame.display.set_caption("reachavoid")
        self._window.blit(self._surface, (0, 0))
        pygame.event.pump()
        pygame.display.flip()
        self._clock.tick(fps)

    def close(self) -> None:
        """Close the window if one is open (the offscreen frame stays usable)."""
        if self._window is not None:
            pygame.display.quit()
            self._window = None
