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

Text is drawn without kerning (``_Font``).

Colours come from ``reachavoid_env.palette``, shared with the tube figures.
"""

from __future__ import annotations

import math
import os
from collections import deque
from collections.abc import Callable
from typing import NamedTuple

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np  # noqa: E402
import pygame  # noqa: E402
import pygame.freetype  # noqa: E402

from reachavoid_env import palette as P  # noqa: E402
from reachavoid_env.game_state import (  # noqa: E402
    AttackerStatus,
    EdgeKind,
    GameState,
    Overlay,
    outcome_line,
)
from reachavoid_env.scenario import GameMap  # noqa: E402
from reachavoid_env.shapes import Shape  # noqa: E402

BLOCK = 16  # frame sizes are multiples of this (H.264 macroblocks)


class EdgeStyle(NamedTuple):
    """How an overlay edge of one kind is drawn: colour, dash and gap lengths (pixels at a
    640-pixel frame; no gap: solid) and the legend's words."""

    color: P.Color
    dash: float
    gap: float
    label: str


EDGE_STYLES: dict[EdgeKind, EdgeStyle] = {
    EdgeKind.ASSIGN: EdgeStyle(P.EDGE, 1.0, 0.0, "assigned (1 vs 1)"),
    EdgeKind.PAIR: EdgeStyle(P.PAIR_EDGE, 10.0, 5.0, "pair: 1 defender on 2 attackers (2 vs 1)"),
    EdgeKind.TEAM: EdgeStyle(P.TEAM_EDGE, 3.0, 4.0, "team: 2 defenders on 1 attacker (1 vs 2)"),
    EdgeKind.RACE: EdgeStyle(P.RACE_EDGE, 2.0, 6.0, "racing to intercept (no guarantee)"),
}


class _Font:
    """pygame's bundled font (FreeSans Bold) drawn by ``pygame.freetype`` without kerning:
    the font's kerning table opens gaps inside words ("at tackers", "guaran teed"), and
    ``pygame.font`` (SDL_ttf) applies it with no way to turn it off. The methods used here
    of ``pygame.font.Font``, at the same sizes."""

    def __init__(self, size: int, bold: bool = False) -> None:
        pygame.freetype.init()
        self._face = pygame.freetype.Font(None, max(1, int(size * 0.6875)))  # pygame.font's
        self._face.origin = True          # scale of its default font; positions: baselines
        self._face.strong = bold
        self._ascent = self._face.get_sized_ascender()
        self._linesize = self._face.get_sized_height() + 1

    def get_linesize(self) -> int:
        return self._linesize

    def size(self, text: str) -> tuple[int, int]:
        return (self._face.get_rect(text).right, self._linesize)

    def render(self, text: str, antialias: bool, color: P.Color) -> pygame.Surface:
        """``text`` on a transparent line ``get_linesize()`` high (``antialias``: always)."""
        surface = pygame.Surface((max(1, self.size(text)[0]), self._linesize), pygame.SRCALPHA)
        self._face.render_to(surface, (0, self._ascent), text, color)
        return surface


def _round_up(pixels: float) -> int:
    return max(BLOCK, int(math.ceil(pixels / BLOCK)) * BLOCK)


def _rgb_surface(width: int, height: int) -> pygame.Surface:
    """A 24-bit surface whose bytes are R, G, B per pixel: ``rgb_array`` is one copy."""
    return pygame.Surface((width, height), 0, 24, (0xFF, 0xFF00, 0xFF0000, 0))


class _LegendEntry(NamedTuple):
    glyph: Callable[[float, float], None]  # draws the sample centred at a pixel
    label: Callable[[GameState], str]      # the words
    widest: str                            # the longest the words can get (layout)
    counts: bool = False                   # the words change with the state


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
        self.width = _round_up(width)
        unit = self.width / 640  # sizes below are tuned for a 640-pixel frame
        self._unit = unit
        self._font = _Font(max(10, round(22 * unit)))
        self._title_font = _Font(max(10, round(22 * unit)), bold=True)
        self._banner_font = _Font(max(10, round(26 * unit)), bold=True)
        self._label_font = _Font(max(8, round(19 * unit)))
        self._legend_font = _Font(max(8, round(19 * unit)))
        self._line_height = self._font.get_linesize()
        self._margin = max(4, round(10 * unit))
        self._halo = max(1, round(2 * unit))
        self._glyph = max(3.0, 7.0 * unit)
        self._trail_width = max(1, round(3 * unit))
        self._edge_width = max(1, round(3 * unit))
        self._header = round(self._margin / 2 + self._title_font.get_linesize()
                             + self._line_height * (1 + self.text_lines) + self._margin / 2)
        self._texts: dict[tuple[str, P.Color, int, bool], pygame.Surface] = {}
        self._fitted: dict[str, str] = {}
        self._legend = self._legend_entries()
        legend_rows, self._legend_pitch = self._layout_legend(self.width - 2 * self._margin)
        self._legend_rows = legend_rows
        legend_height = len(legend_rows) * self._legend_pitch + self._margin

        domain_w, domain_h = game_map.size
        scale = (self.width - 2 * self._margin) / domain_w
        chrome = self._header + 2 * self._margin + legend_height
        if height is None:
            self.height = _round_up(chrome + domain_h * scale)
        else:
            self.height = _round_up(height)
            scale = min(scale, (self.height - chrome) / domain_h)
            if scale <= 0:
                raise ValueError(f"height: {height} pixels leave no room for the map")
        self._scale = scale
        free_x = self.width - domain_w * scale
        free_y = self.height - chrome - domain_h * scale
        self._origin = (free_x / 2, self._header + self._margin + free_y / 2)
        self._legend_top = self.height - legend_height

        self._surface = _rgb_surface(self.width, self.height)
        self._disc = self._draw_disc()
        self._background = self._draw_background()
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

    def _field(self) -> pygame.Rect:
        xmin, xmax, ymin, ymax = self.game_map.domain
        (left, top), (right, bottom) = self._pixel((xmin, ymax)), self._pixel((xmax, ymin))
        return pygame.Rect(round(left), round(top), round(right - left), round(bottom - top))

    # -- text ----------------------------------------------------------------------------

    def _text(self, words: str, color: P.Color, font: _Font,
              halo: bool = False) -> pygame.Surface:
        """``words`` rendered (remembered), with a white halo of ``self._halo`` pixels
        around every letter when ``halo`` (readable over obstacles, trails and edges)."""
        key = (words, color, id(font), halo)
        surface = self._texts.get(key)
        if surface is None:
            body = font.render(words, True, color)
            if halo:
                r = self._halo
                outline = font.render(words, True, P.HALO)
                surface = pygame.Surface((body.get_width() + 2 * r, body.get_height() + 2 * r),
                                         pygame.SRCALPHA)
                for dx in range(-r, r + 1):
                    for dy in range(-r, r + 1):
                        if dx * dx + dy * dy <= r * r + 1:
                            surface.blit(outline, (r + dx, r + dy))
                surface.blit(body, (r, r))
            else:
                surface = body
            if len(self._texts) > 512:  # words that change every frame (the clock)
                self._texts.clear()
            self._texts[key] = surface
        return surface

    def _fit(self, line: str, pixels: int, font: _Font | None = None) -> str:
        """``line``, cut short with "..." if it is wider than ``pixels`` (remembered)."""
        font = font or self._font
        key = f"{id(font)}:{pixels}:{line}"
        fitted = self._fitted.get(key)
        if fitted is None:
            fitted = line
            if len(line) > pixels or font.size(line)[0] > pixels:
                # the longest prefix that fits, by bisection (a character is >= 1 pixel
                # wide, so no more than ``pixels`` of them can fit)
                low, high = 0, min(len(line), pixels)
                while low < high:
                    mid = (low + high + 1) // 2
                    if font.size(line[:mid] + "...")[0] <= pixels:
                        low = mid
                    else:
                        high = mid - 1
                fitted = line[:low] + "..."
            if len(self._fitted) > 256:  # lines that change every frame
                self._fitted.clear()
            self._fitted[key] = fitted
        return fitted

    # -- static layers -------------------------------------------------------------------

    def _draw_shape(self, surface: pygame.Surface, shape: Shape, fill: P.Color,
                    edge: P.Color) -> None:
        points = [tuple(p) for p in self.to_pixels(shape.outline()).tolist()]
        pygame.draw.polygon(surface, fill, points)
        pygame.draw.aalines(surface, edge, True, points)
        pygame.draw.polygon(surface, edge, points, width=2)

    def _draw_background(self) -> pygame.Surface:
        """What every frame starts from: the map without players, and the legend's fixed
        parts."""
        surface = self._surface
        surface.fill(P.FRAME)
        field = self._field()
        pygame.draw.rect(surface, P.FIELD, field)
        for shape in self.game_map.target:
            self._draw_shape(surface, shape, P.TARGET, P.TARGET_EDGE)
        for shape in self.game_map.obstacles:
            self._draw_shape(surface, shape, P.OBSTACLE, P.OBSTACLE)
        pygame.draw.rect(surface, P.BORDER, field.inflate(4, 4), width=2)
        rule = self._legend_top - self._margin // 2
        pygame.draw.line(surface, P.blend(P.FRAME, P.BORDER, 0.3), (self._margin, rule),
                         (self.width - self._margin, rule))
        self._draw_legend(None)
        return surface.copy()

    def _draw_disc(self) -> pygame.Surface:
        radius = self.capture_radius * self._scale
        size = int(math.ceil(2 * radius)) + 4
        disc = pygame.Surface((size, size), pygame.SRCALPHA)
        center = (size / 2, size / 2)
        pygame.draw.aacircle(disc, (*P.DEFENDER, 38), center, radius)
        pygame.draw.aacircle(disc, (*P.DEFENDER, 150), center, radius, width=1)
        return disc

    # -- the legend ----------------------------------------------------------------------

    def _legend_entries(self) -> list[list[_LegendEntry]]:
        """Every glyph of the map with its words, in groups (the map and the defenders, the
        attackers with their counts, the shared games)."""

        def swatch(fill: P.Color, edge: P.Color) -> Callable[[float, float], None]:
            def draw(x: float, y: float) -> None:
                w, h = self._glyph * 1.8, self._glyph * 1.3
                box = pygame.Rect(round(x - w / 2), round(y - h / 2), round(w), round(h))
                pygame.draw.rect(self._surface, fill, box)
                pygame.draw.rect(self._surface, edge, box, width=max(1, round(self._unit)))
            return draw

        def disc(x: float, y: float) -> None:
            r = self._glyph * 1.1
            sample = pygame.Surface((round(2 * r) + 2, round(2 * r) + 2), pygame.SRCALPHA)
            c = sample.get_width() / 2
            pygame.draw.aacircle(sample, (*P.DEFENDER, 38), (c, c), r)
            pygame.draw.aacircle(sample, (*P.DEFENDER, 150), (c, c), r, width=1)
            self._surface.blit(sample, (round(x - c), round(y - c)))

        def line(kind: EdgeKind) -> Callable[[float, float], None]:
            def draw(x: float, y: float) -> None:
                half = self._glyph * 1.6
                self._draw_edge(kind, np.array([(x - half, y), (x + half, y)]))
            return draw

        def trails(x: float, y: float) -> None:   # an attacker's over a defender's, old to new
            half, steps, apart = self._glyph * 1.6, 12, self._trail_width
            for color, dy in ((P.ATTACKER, -apart), (P.DEFENDER, apart)):
                self._draw_trail(deque((self.trail_seconds * k / steps,
                                        x - half + 2 * half * k / steps, y + dy)
                                       for k in range(steps + 1)), self.trail_seconds, color)

        wide = "88"  # room for two-digit counts
        edges = {kind: _LegendEntry(line(kind), lambda s, words=style.label: words, style.label)
                 for kind, style in EDGE_STYLES.items()}
        recent = f"trails: the last {self.trail_seconds:g} s"
        faded = [_LegendEntry(trails, lambda s: recent, recent)] if self.trail_seconds else []
        return [
            [_LegendEntry(swatch(P.TARGET, P.TARGET_EDGE), lambda s: "target", "target"),
             _LegendEntry(swatch(P.OBSTACLE, P.OBSTACLE), lambda s: "obstacle", "obstacle"),
             _LegendEntry(self._draw_square, lambda s: "defender", "defender"),
             _LegendEntry(disc, lambda s: "capture disc", "capture disc"),
             edges[EdgeKind.ASSIGN]],
            [_LegendEntry(self._draw_triangle,
                          lambda s: f"attacker in play: {int(s.active_attackers.sum())}",
                          f"attacker in play: {wide}", counts=True),
             _LegendEntry(self._draw_plus, lambda s: f"captured: {len(s.captured)}",
                          f"captured: {wide}", counts=True),
             _LegendEntry(self._draw_arrival, lambda s: f"reached target: {len(s.arrived)}",
                          f"reached target: {wide}", counts=True), *faded],
            [edges[EdgeKind.PAIR], edges[EdgeKind.TEAM], edges[EdgeKind.RACE]],
        ]

    def _layout_legend(self, room: int) -> tuple[list[list[tuple[_LegendEntry, int]]], int]:
        """The legend's groups, each from a new row, flowed into rows of at most ``room``
        pixels: per row, ``(entry, x offset)``; and the row pitch in pixels."""
        sample = round(self._glyph * 3.6)  # the glyph's slot before the words
        gap = round(14 * self._unit)
        rows: list[list[tuple[_LegendEntry, int]]] = []
        for group in self._legend:
            rows.append([])
            x = 0
            for entry in group:
                width = sample + self._legend_font.size(entry.widest)[0]
                if rows[-1] and x + width > room:
                    rows.append([])
                    x = 0
                rows[-1].append((entry, x))
                x += width + gap
        return rows, max(self._legend_font.get_linesize(), round(2.6 * self._glyph)) + 2

    def _draw_legend(self, state: GameState | None) -> None:
        """The legend's glyphs and fixed words (``state`` None: drawn once, into the
        background), or the words that count attackers in ``state``."""
        sample = round(self._glyph * 3.6)
        for r, row in enumerate(self._legend_rows):
            middle = self._legend_top + (r + 0.5) * self._legend_pitch
            for entry, x in row:
                left = self._margin + x
                if state is None:
                    entry.glyph(left + sample / 2 - self._glyph * 0.4, middle)
                if (state is None) == entry.counts:
                    continue
                words = self._text(entry.label(state), P.TEXT, self._legend_font)
                self._surface.blit(words, (left + sample, round(middle - words.get_height() / 2)))

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

    def draw(self, state: GameState, overlay: Overlay | None = None, *, title: str = "",
             game_over: bool = False) -> None:
        """Render ``state`` (and ``overlay``) into the offscreen frame, under ``title``;
        ``game_over`` adds the banner saying how the episode ended.

        Successive calls are taken as one episode (trails grow) until ``reset`` or until
        the state's step goes backwards.
        """
        self._update_trails(state)
        surface = self._surface
        surface.blit(self._background, (0, 0))
        for name, trail in self._trails.items():
            color = P.ATTACKER if name.startswith("attacker") else P.DEFENDER
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
        for x, y in defenders.tolist():
            self._draw_square(x, y)
        for i, (status, (x, y)) in enumerate(zip(state.attacker_status, attackers.tolist(),
                                                 strict=True)):
            self._draw_label(f"A{i}", x, y, P.ATTACKER if status is AttackerStatus.ACTIVE
                             else P.blend(P.ATTACKER, P.FIELD, 0.45))
        for j, (x, y) in enumerate(defenders.tolist()):
            self._draw_label(f"D{j}", x, y, P.DEFENDER)
        self._draw_header(state, overlay, title)
        self._draw_legend(state)
        if game_over:
            self._draw_banner(state)

    def _draw_trail(self, trail: deque[tuple[float, float, float]], now: float,
                    color: P.Color) -> None:
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
                shade = P.blend(color, P.FIELD, 0.35 + 0.6 * (band - 1) / bands)
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
        pygame.draw.polygon(self._surface, P.ATTACKER, corners)
        pygame.draw.aalines(self._surface, P.blend(P.ATTACKER, (0, 0, 0), 0.4), True, corners)

    def _draw_square(self, x: float, y: float) -> None:
        side = round(2 * self._glyph * 0.85)
        square = pygame.Rect(0, 0, side, side)
        square.center = (round(x), round(y))
        pygame.draw.rect(self._surface, P.DEFENDER, square)
        pygame.draw.rect(self._surface, P.blend(P.DEFENDER, (0, 0, 0), 0.4), square, width=1)

    def _draw_plus(self, x: float, y: float) -> None:
        g, w = self._glyph, max(2, round(self._glyph / 3))
        pygame.draw.line(self._surface, P.CAPTURED, (x - g, y), (x + g, y), w)
        pygame.draw.line(self._surface, P.CAPTURED, (x, y - g), (x, y + g), w)

    def _draw_arrival(self, x: float, y: float) -> None:
        g = self._glyph
        pygame.draw.aacircle(self._surface, P.ATTACKER, (x, y), g * 1.3,
                             width=max(2, round(g / 3)))
        pygame.draw.aacircle(self._surface, P.ATTACKER, (x, y), g * 0.4)

    def _draw_label(self, text: str, x: float, y: float, color: P.Color) -> None:
        label = self._text(text, color, self._label_font, halo=True)
        offset = self._glyph * 1.1
        self._surface.blit(label, (round(x + offset), round(y - offset - label.get_height() / 2)))

    def _draw_edge(self, kind: EdgeKind, pixels: np.ndarray) -> None:
        """A line through ``pixels`` ``(K, 2)`` (K >= 2) in ``kind``'s style, its dashes
        running on from segment to segment, on a white halo (readable over obstacles and
        trails)."""
        style = EDGE_STYLES[kind]
        steps = np.diff(pixels, axis=0)
        lengths = np.hypot(steps[:, 0], steps[:, 1])
        starts = np.concatenate([[0.0], np.cumsum(lengths)])
        length = float(starts[-1])
        if length == 0:
            return
        units = steps / np.maximum(lengths, 1e-300)[:, None]

        def at(a: float) -> tuple[float, float]:
            k = min(int(np.searchsorted(starts, a, side="right")) - 1, len(lengths) - 1)
            (x, y), (ux, uy) = pixels[k].tolist(), units[k].tolist()
            return x + ux * (a - float(starts[k])), y + uy * (a - float(starts[k]))

        if style.gap == 0:
            pieces = [(0.0, length)]
        else:
            dash, period = style.dash * self._unit, (style.dash + style.gap) * self._unit
            pieces = [(a, min(a + dash, length)) for a in np.arange(0.0, length, period).tolist()]
        runs = [[at(a)] + [tuple(p) for p in pixels[1:-1][(starts[1:-1] > a)
                                                        & (starts[1:-1] < b)].tolist()]
                + [at(b)] for a, b in pieces]
        for color, width in ((P.HALO, self._edge_width + 2 * max(1, round(self._unit))),
                             (style.color, self._edge_width)):
            for run in runs:
                for start, end in zip(run, run[1:], strict=False):
                    pygame.draw.line(self._surface, color, start, end, width)

    def _draw_edges(self, overlay: Overlay, state: GameState, attackers: np.ndarray,
                    defenders: np.ndarray) -> None:
        attacker_index = {n: i for i, n in enumerate(state.attacker_names)}
        defender_index = {n: j for j, n in enumerate(state.defender_names)}
        routes = {(r.defender, r.attacker): r.points for r in overlay.routes}
        for defender, attacker, kind in overlay.kinded_edges:
            if defender not in defender_index:
                raise ValueError(f"overlay edge ({defender!r}, {attacker!r}): unknown defender "
                                 f"{defender!r}")
            if attacker not in attacker_index:
                raise ValueError(f"overlay edge ({defender!r}, {attacker!r}): unknown attacker "
                                 f"{attacker!r}")
            i = attacker_index[attacker]
            if state.attacker_status[i] is not AttackerStatus.ACTIVE:
                continue  # the attacker has left the game: nothing to assign
            route = routes.get((defender, attacker), ())
            between = self.to_pixels(np.array(route[1:-1], dtype=np.float64).reshape(-1, 2))
            self._draw_edge(kind, np.concatenate([defenders[defender_index[defender]][None],
                                                  between, attackers[i][None]]))

    def _draw_header(self, state: GameState, overlay: Overlay | None, title: str) -> None:
        """The title, the clock, then the overlay's text lines."""
        pad, room = self._margin, self.width - 2 * self._margin
        top = round(self._margin / 2)
        if title:
            words = self._text(self._fit(title, room, self._title_font), P.TEXT,
                               self._title_font)
            self._surface.blit(words, (pad, top))
        top += self._title_font.get_linesize()
        clock = self._font.render(f"t = {state.time:.3f} s   step {state.step}", True, P.TEXT)
        self._surface.blit(clock, (pad, top))
        lines = list(overlay.lines) if overlay is not None else []
        if len(lines) > self.text_lines:
            lines = lines[:self.text_lines]
            lines[-1] += " ..."
        for k, line in enumerate(lines, start=1):
            text = self._text(self._fit(line, room), P.TEXT_DIM, self._font)
            self._surface.blit(text, (pad, top + k * self._line_height))

    def _draw_banner(self, state: GameState) -> None:
        """How the episode ended, in a box across the top of the map (wrapped to the
        map's width)."""
        total, arrived = len(state.attacker_status), len(state.arrived)
        field = self._field()
        room = field.width - 4 * self._margin
        lines = [""]
        for word in outcome_line(total, len(state.captured), arrived).split(" "):
            longer = f"{lines[-1]} {word}".strip()
            if lines[-1] and self._banner_font.size(longer)[0] > room:
                lines.append(word)
            else:
                lines[-1] = longer
        texts = [self._text(self._fit(line, room, self._banner_font), P.TEXT,
                            self._banner_font) for line in lines]
        pitch = self._banner_font.get_linesize()
        box = pygame.Rect(0, 0, max(t.get_width() for t in texts) + 2 * self._margin,
                          pitch * len(texts) + self._margin)
        box.midtop = (field.centerx, field.top + self._margin)
        panel = pygame.Surface(box.size, pygame.SRCALPHA)
        panel.fill((*P.HALO, 230))
        self._surface.blit(panel, box.topleft)
        edge = P.ATTACKER if arrived else P.DEFENDER
        pygame.draw.rect(self._surface, edge, box, width=max(2, round(3 * self._unit)))
        for k, text in enumerate(texts):
            self._surface.blit(text, text.get_rect(midtop=(box.centerx, box.top
                                                           + self._margin // 2 + k * pitch)))

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
