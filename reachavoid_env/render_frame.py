"""The frame that the renderer's layers (``render``) draw on: its sizes, scaled with its
width; its fonts and remembered text; where the header, the map and the legend sit; the
24-bit surface.

Frame sizes are multiples of ``BLOCK`` pixels (video encoders then keep the size). Text is
drawn without kerning (``Font``).
"""

from __future__ import annotations

import math
import os

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np  # noqa: E402
import pygame  # noqa: E402
import pygame.freetype  # noqa: E402

from reachavoid_env import palette as P  # noqa: E402
from reachavoid_env.scenario import GameMap  # noqa: E402

BLOCK = 16  # frame sizes are multiples of this (H.264 macroblocks)


class Font:
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


def round_up(pixels: float) -> int:
    """A frame length: ``pixels`` rounded up to a whole number of blocks.

    Args:
        pixels: the length wanted.

    Returns:
        The least multiple of ``BLOCK`` that is at least ``pixels``, and at least ``BLOCK``.
    """
    return max(BLOCK, int(math.ceil(pixels / BLOCK)) * BLOCK)


def rgb_surface(width: int, height: int) -> pygame.Surface:
    """A 24-bit surface whose bytes are R, G, B per pixel: ``rgb_array`` is one copy."""
    return pygame.Surface((width, height), 0, 24, (0xFF, 0xFF00, 0xFF0000, 0))


class Frame:
    """The frame of one map, ``width`` pixels wide (rounded up to a multiple of
    ``BLOCK``): the sizes of glyphs, lines and margins, tuned for a 640-pixel frame and
    scaled with the width; the fonts; text, remembered; the header's height (the title,
    the clock and ``text_lines`` lines of overlay text).

    ``place`` then sizes the frame around the map, once the legend's height is known: the
    frame's height, the map's scale and origin, the legend's top and the ``surface`` that
    every layer draws on.
    """

    def __init__(self, game_map: GameMap, width: int, text_lines: int) -> None:
        self.game_map = game_map
        self.text_lines = text_lines
        self.width = round_up(width)
        unit = self.width / 640  # sizes below are tuned for a 640-pixel frame
        self.unit = unit
        self.font = Font(max(10, round(22 * unit)))
        self.title_font = Font(max(10, round(22 * unit)), bold=True)
        self.banner_font = Font(max(10, round(26 * unit)), bold=True)
        self.label_font = Font(max(8, round(19 * unit)))
        self.legend_font = Font(max(8, round(19 * unit)))
        self.line_height = self.font.get_linesize()
        self.margin = max(4, round(10 * unit))
        self.halo = max(1, round(2 * unit))
        self.glyph = max(3.0, 7.0 * unit)
        self.trail_width = max(1, round(3 * unit))
        self.edge_width = max(1, round(3 * unit))
        self.header = round(self.margin / 2 + self.title_font.get_linesize()
                            + self.line_height * (1 + text_lines) + self.margin / 2)
        self._texts: dict[tuple[str, P.Color, int, bool], pygame.Surface] = {}
        self._fitted: dict[str, str] = {}

    def place(self, legend_height: int, height: int | None) -> None:
        """Put the map between the header and the legend, at the largest scale that fits.

        Args:
            legend_height: the legend's height in pixels, at the bottom of the frame.
            height: the frame's height in pixels (rounded up to a multiple of ``BLOCK``);
                None: the height at which the map fills the width between the margins.

        Raises:
            ValueError: ``height`` leaves no room for the map.
        """
        domain_w, domain_h = self.game_map.size
        scale = (self.width - 2 * self.margin) / domain_w
        chrome = self.header + 2 * self.margin + legend_height
        if height is None:
            self.height = round_up(chrome + domain_h * scale)
        else:
            self.height = round_up(height)
            scale = min(scale, (self.height - chrome) / domain_h)
            if scale <= 0:
                raise ValueError(f"height: {height} pixels leave no room for the map")
        self.scale = scale
        free_x = self.width - domain_w * scale
        free_y = self.height - chrome - domain_h * scale
        self.origin = (free_x / 2, self.header + self.margin + free_y / 2)
        self.legend_top = self.height - legend_height
        self.surface = rgb_surface(self.width, self.height)

    # -- coordinates ---------------------------------------------------------------------

    def to_pixels(self, points: np.ndarray) -> np.ndarray:
        """Frame pixels of map points.

        Args:
            points: ``(..., 2)`` map coordinates (map units, ``y`` up).

        Returns:
            ``(..., 2)`` float pixels (``y`` down): ``origin`` plus ``scale`` times the
            offset from the domain's top-left corner.
        """
        p = np.asarray(points, dtype=np.float64)
        xmin, _, _, ymax = self.game_map.domain
        x = self.origin[0] + (p[..., 0] - xmin) * self.scale
        y = self.origin[1] + (ymax - p[..., 1]) * self.scale
        return np.stack([x, y], axis=-1)

    def pixel(self, point: np.ndarray | tuple[float, float]) -> tuple[float, float]:
        """The frame pixel of one map point (``to_pixels``)."""
        x, y = self.to_pixels(np.asarray(point))
        return (float(x), float(y))

    def field(self) -> pygame.Rect:
        """The domain's rectangle in the frame (pixels, rounded)."""
        xmin, xmax, ymin, ymax = self.game_map.domain
        (left, top), (right, bottom) = self.pixel((xmin, ymax)), self.pixel((xmax, ymin))
        return pygame.Rect(round(left), round(top), round(right - left), round(bottom - top))

    # -- text ----------------------------------------------------------------------------

    def text(self, words: str, color: P.Color, font: Font,
             halo: bool = False) -> pygame.Surface:
        """``words`` rendered (remembered), with a white halo of ``self.halo`` pixels
        around every letter when ``halo`` (readable over obstacles, trails and edges)."""
        key = (words, color, id(font), halo)
        surface = self._texts.get(key)
        if surface is None:
            body = font.render(words, True, color)
            if halo:
                r = self.halo
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

    def fit(self, line: str, pixels: int, font: Font | None = None) -> str:
        """A line cut to a width (remembered).

        Args:
            line: the words.
            pixels: the width it may take.
            font: the font it is drawn in (default ``self.font``).

        Returns:
            ``line`` if it fits, else its longest prefix that fits with "..." after it,
            found by bisection: a character is at least a pixel wide, so no more than
            ``pixels`` of them can fit.
        """
        font = font or self.font
        key = f"{id(font)}:{pixels}:{line}"
        fitted = self._fitted.get(key)
        if fitted is None:
            fitted = line
            if len(line) > pixels or font.size(line)[0] > pixels:
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
