"""The renderer's legend (``render``): every glyph, colour and line style of the map in
words (the trails and how much time they cover included), with the counts of attackers in
play, captured and arrived, in rows under the map.
"""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Callable
from typing import NamedTuple

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np  # noqa: E402
import pygame  # noqa: E402

from reachavoid_env import palette as P  # noqa: E402
from reachavoid_env.game_state import GameState  # noqa: E402
from reachavoid_env.overlay import EdgeKind  # noqa: E402
from reachavoid_env.render_frame import Frame  # noqa: E402
from reachavoid_env.render_overlay import EDGE_STYLES, Edges  # noqa: E402
from reachavoid_env.render_players import Players, Trails  # noqa: E402


class LegendEntry(NamedTuple):
    """One glyph of the legend and its words."""

    glyph: Callable[[float, float], None]  # draws the sample centred at a pixel
    label: Callable[[GameState], str]      # the words
    widest: str                            # the longest the words can get (layout)
    counts: bool = False                   # the words change with the state


class Legend:
    """The legend of a frame whose players, trails and edges are drawn by ``players``,
    ``trails`` and ``edges``: ``groups`` of entries (the map and the defenders, the
    attackers with their counts, the shared games), each from a new row, flowed into rows
    as wide as the frame less its margins (``rows``, ``pitch`` pixels apart); ``height``,
    the pixels it takes at the bottom of the frame."""

    def __init__(self, frame: Frame, players: Players, trails: Trails, edges: Edges) -> None:
        self.frame = frame
        self.groups = self._entries(players, trails, edges)
        self.rows, self.pitch = self._layout(frame.width - 2 * frame.margin)
        self.height = len(self.rows) * self.pitch + frame.margin

    def _entries(self, players: Players, trails: Trails,
                 edges: Edges) -> list[list[LegendEntry]]:
        """Every glyph of the map with its words, in groups."""
        frame = self.frame

        def swatch(fill: P.Color, edge: P.Color) -> Callable[[float, float], None]:
            def draw(x: float, y: float) -> None:
                w, h = frame.glyph * 1.8, frame.glyph * 1.3
                box = pygame.Rect(round(x - w / 2), round(y - h / 2), round(w), round(h))
                pygame.draw.rect(frame.surface, fill, box)
                pygame.draw.rect(frame.surface, edge, box, width=max(1, round(frame.unit)))
            return draw

        def disc(x: float, y: float) -> None:
            r = frame.glyph * 1.1
            sample = pygame.Surface((round(2 * r) + 2, round(2 * r) + 2), pygame.SRCALPHA)
            c = sample.get_width() / 2
            pygame.draw.aacircle(sample, (*P.DEFENDER, 38), (c, c), r)
            pygame.draw.aacircle(sample, (*P.DEFENDER, 150), (c, c), r, width=1)
            frame.surface.blit(sample, (round(x - c), round(y - c)))

        def line(kind: EdgeKind) -> Callable[[float, float], None]:
            def draw(x: float, y: float) -> None:
                half = frame.glyph * 1.6
                edges.draw(kind, np.array([(x - half, y), (x + half, y)]))
            return draw

        def recent(x: float, y: float) -> None:  # an attacker's over a defender's, old to new
            half, steps, apart = frame.glyph * 1.6, 12, frame.trail_width
            for color, dy in ((P.ATTACKER, -apart), (P.DEFENDER, apart)):
                trails.draw(deque((trails.seconds * k / steps,
                                   x - half + 2 * half * k / steps, y + dy)
                                  for k in range(steps + 1)), trails.seconds, color)

        wide = "88"  # room for two-digit counts
        lines = {kind: LegendEntry(line(kind), lambda s, words=style.label: words, style.label)
                 for kind, style in EDGE_STYLES.items()}
        covered = f"trails: the last {trails.seconds:g} s"
        faded = [LegendEntry(recent, lambda s: covered, covered)] if trails.seconds else []
        return [
            [LegendEntry(swatch(P.TARGET, P.TARGET_EDGE), lambda s: "target", "target"),
             LegendEntry(swatch(P.OBSTACLE, P.OBSTACLE), lambda s: "obstacle", "obstacle"),
             LegendEntry(players.draw_square, lambda s: "defender", "defender"),
             LegendEntry(disc, lambda s: "capture disc", "capture disc"),
             lines[EdgeKind.ASSIGN]],
            [LegendEntry(players.draw_triangle,
                         lambda s: f"attacker in play: {int(s.active_attackers.sum())}",
                         f"attacker in play: {wide}", counts=True),
             LegendEntry(players.draw_plus, lambda s: f"captured: {len(s.captured)}",
                         f"captured: {wide}", counts=True),
             LegendEntry(players.draw_arrival, lambda s: f"reached target: {len(s.arrived)}",
                         f"reached target: {wide}", counts=True), *faded],
            [lines[EdgeKind.PAIR], lines[EdgeKind.TEAM], lines[EdgeKind.RACE]],
        ]

    def _layout(self, room: int) -> tuple[list[list[tuple[LegendEntry, int]]], int]:
        """The groups flowed into rows.

        Args:
            room: the width of a row in pixels.

        Returns:
            Per row, ``(entry, x offset)``: an entry takes its glyph's slot and its widest
            words, with a gap before the next one; and the row pitch in pixels (the
            taller of a line of text and 2.6 glyph sizes, plus 2).
        """
        frame = self.frame
        sample = round(frame.glyph * 3.6)  # the glyph's slot before the words
        gap = round(14 * frame.unit)
        rows: list[list[tuple[LegendEntry, int]]] = []
        for group in self.groups:
            rows.append([])
            x = 0
            for entry in group:
                width = sample + frame.legend_font.size(entry.widest)[0]
                if rows[-1] and x + width > room:
                    rows.append([])
                    x = 0
                rows[-1].append((entry, x))
                x += width + gap
        return rows, max(frame.legend_font.get_linesize(), round(2.6 * frame.glyph)) + 2

    def draw(self, state: GameState | None) -> None:
        """The glyphs and fixed words (``state`` None: drawn once, into the background),
        or the words that count attackers in ``state``."""
        frame = self.frame
        sample = round(frame.glyph * 3.6)
        for r, row in enumerate(self.rows):
            middle = frame.legend_top + (r + 0.5) * self.pitch
            for entry, x in row:
                left = frame.margin + x
                if state is None:
                    entry.glyph(left + sample / 2 - frame.glyph * 0.4, middle)
                if (state is None) == entry.counts:
                    continue
                words = frame.text(entry.label(state), P.TEXT, frame.legend_font)
                frame.surface.blit(words, (left + sample, round(middle - words.get_height() / 2)))
