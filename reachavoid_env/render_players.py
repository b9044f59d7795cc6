"""The renderer's players (``render``): fading trails, and the glyphs of attackers (red
triangles, pointing where they head; a ``+`` where one was captured, a ring where one
arrived) and defenders (blue squares, with their capture discs), named by haloed labels.
"""

from __future__ import annotations

import math
import os
from collections import deque
from functools import cached_property

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np  # noqa: E402
import pygame  # noqa: E402

from reachavoid_env import palette as P  # noqa: E402
from reachavoid_env.game_state import AttackerStatus, GameState  # noqa: E402
from reachavoid_env.render_frame import Frame  # noqa: E402

Trail = deque[tuple[float, float, float]]
"""One player's recent way: ``(time, x pixel, y pixel)``, oldest first."""


class Trails:
    """Every player's recent way through one episode, covering ``seconds`` of game time,
    and how it is drawn: fading with age."""

    def __init__(self, frame: Frame, seconds: float) -> None:
        self.frame = frame
        self.seconds = seconds
        self._trails: dict[str, Trail] = {}
        self._last: GameState | None = None

    def reset(self) -> None:
        """Forget trails (a new episode starts)."""
        self._trails.clear()
        self._last = None

    def update(self, state: GameState) -> None:
        """Add ``state``'s positions (2 pixels or more from a trail's last point) and drop
        points older than ``seconds``; a state that cannot follow the last one (time going
        back, other teams) starts a new episode."""
        last = self._last
        if last is not None and (state.step < last.step or state.time < last.time
                                 or len(state.attacker_status) != len(last.attacker_status)
                                 or len(state.defender_positions)
                                 != len(last.defender_positions)):
            self.reset()
        names = state.attacker_names + state.defender_names
        pixels = self.frame.to_pixels(np.concatenate([state.attacker_positions,
                                                      state.defender_positions]))
        spacing = 2.0  # pixels between stored trail points
        for name, (x, y) in zip(names, pixels.tolist(), strict=True):
            trail = self._trails.setdefault(name, deque())
            if not trail or math.hypot(x - trail[-1][1], y - trail[-1][2]) >= spacing:
                trail.append((state.time, x, y))
            horizon = state.time - self.seconds
            while len(trail) > 1 and trail[0][0] < horizon:
                trail.popleft()
        self._last = state

    def draw_all(self, now: float) -> None:
        """Every player's trail at game time ``now``, in its side's colour."""
        for name, trail in self._trails.items():
            color = P.ATTACKER if name.startswith("attacker") else P.DEFENDER
            self.draw(trail, now, color)

    def heading(self, name: str) -> float:
        """Where player ``name`` heads: the direction of its trail's last step (radians,
        counterclockwise from the ``x`` axis, ``y`` up); upward until it has moved."""
        trail = self._trails.get(name)
        if trail is None or len(trail) < 2:
            return math.pi / 2
        (_, x0, y0), (_, x1, y1) = trail[-2], trail[-1]
        return math.atan2(y0 - y1, x1 - x0)

    def draw(self, trail: Trail, now: float, color: P.Color) -> None:
        """One trail, cut into runs by age, each paler than the next newer one.

        Args:
            trail: the points to draw.
            now: the game time of the frame (seconds).
            color: the newest run's colour, before blending with the field.
        """
        if len(trail) < 2 or self.seconds == 0:
            return
        bands = 6
        points = list(trail)
        # Split the trail into `bands` runs by age; older runs are paler.
        start = 0
        for band in range(bands, 0, -1):
            newest = now - self.seconds * (band - 1) / bands
            end = start
            while end < len(points) and points[end][0] <= newest:
                end += 1
            run = points[max(0, start - 1):end]
            if len(run) >= 2:
                shade = P.blend(color, P.FIELD, 0.35 + 0.6 * (band - 1) / bands)
                pixels = [(p[1], p[2]) for p in run]
                width = self.frame.trail_width
                if width > 1:
                    pygame.draw.lines(self.frame.surface, shade, False, pixels, width - 1)
                pygame.draw.aalines(self.frame.surface, shade, False, pixels)
            start = end


class Players:
    """The players' glyphs, capture discs and labels; an active attacker's triangle points
    where its trail heads (``trails``)."""

    def __init__(self, frame: Frame, capture_radius: float, trails: Trails) -> None:
        self.frame = frame
        self.capture_radius = capture_radius
        self.trails = trails

    @cached_property
    def disc(self) -> pygame.Surface:
        """A defender's capture disc at the map's scale (made on first use: after
        ``Frame.place``)."""
        radius = self.capture_radius * self.frame.scale
        size = int(math.ceil(2 * radius)) + 4
        disc = pygame.Surface((size, size), pygame.SRCALPHA)
        center = (size / 2, size / 2)
        pygame.draw.aacircle(disc, (*P.DEFENDER, 38), center, radius)
        pygame.draw.aacircle(disc, (*P.DEFENDER, 150), center, radius, width=1)
        return disc

    def draw_discs(self, defenders: np.ndarray) -> None:
        """The capture discs around ``defenders`` ``(N, 2)`` pixels."""
        half = self.disc.get_width() / 2
        for x, y in defenders.tolist():
            self.frame.surface.blit(self.disc, (round(x - half), round(y - half)))

    def draw(self, state: GameState, attackers: np.ndarray, defenders: np.ndarray) -> None:
        """The glyphs of ``state``'s players at ``attackers`` ``(M, 2)`` and ``defenders``
        ``(N, 2)`` pixels, then their labels (an attacker out of play's paler)."""
        for i, (status, (x, y)) in enumerate(zip(state.attacker_status, attackers.tolist(),
                                                 strict=True)):
            if status is AttackerStatus.ACTIVE:
                self.draw_triangle(x, y, self.trails.heading(f"attacker_{i}"))
            elif status is AttackerStatus.CAPTURED:
                self.draw_plus(x, y)
            else:
                self.draw_arrival(x, y)
        for x, y in defenders.tolist():
            self.draw_square(x, y)
        for i, (status, (x, y)) in enumerate(zip(state.attacker_status, attackers.tolist(),
                                                 strict=True)):
            self._draw_label(f"A{i}", x, y, P.ATTACKER if status is AttackerStatus.ACTIVE
                             else P.blend(P.ATTACKER, P.FIELD, 0.45))
        for j, (x, y) in enumerate(defenders.tolist()):
            self._draw_label(f"D{j}", x, y, P.DEFENDER)

    def draw_triangle(self, x: float, y: float, heading: float = math.pi / 2) -> None:
        """An attacker's glyph.

        Args:
            x, y: its centre (pixels).
            heading: where it points (radians, counterclockwise from the ``x`` axis,
                ``y`` up): its tip there, the other corners 2.4 radians either side.
        """
        g = self.frame.glyph * 1.25
        corners = [(x + g * math.cos(heading + turn), y - g * math.sin(heading + turn))
                   for turn in (0.0, 2.4, -2.4)]
        pygame.draw.polygon(self.frame.surface, P.ATTACKER, corners)
        pygame.draw.aalines(self.frame.surface, P.blend(P.ATTACKER, (0, 0, 0), 0.4), True,
                            corners)

    def draw_square(self, x: float, y: float) -> None:
        """A defender's glyph centred at pixel ``(x, y)``."""
        side = round(2 * self.frame.glyph * 0.85)
        square = pygame.Rect(0, 0, side, side)
        square.center = (round(x), round(y))
        pygame.draw.rect(self.frame.surface, P.DEFENDER, square)
        pygame.draw.rect(self.frame.surface, P.blend(P.DEFENDER, (0, 0, 0), 0.4), square,
                         width=1)

    def draw_plus(self, x: float, y: float) -> None:
        """A captured attacker's ``+`` centred at pixel ``(x, y)``."""
        g, w = self.frame.glyph, max(2, round(self.frame.glyph / 3))
        pygame.draw.line(self.frame.surface, P.CAPTURED, (x - g, y), (x + g, y), w)
        pygame.draw.line(self.frame.surface, P.CAPTURED, (x, y - g), (x, y + g), w)

    def draw_arrival(self, x: float, y: float) -> None:
        """An arrived attacker's ring centred at pixel ``(x, y)``."""
        g = self.frame.glyph
        pygame.draw.aacircle(self.frame.surface, P.ATTACKER, (x, y), g * 1.3,
                             width=max(2, round(g / 3)))
        pygame.draw.aacircle(self.frame.surface, P.ATTACKER, (x, y), g * 0.4)

    def _draw_label(self, text: str, x: float, y: float, color: P.Color) -> None:
        frame = self.frame
        label = frame.text(text, color, frame.label_font, halo=True)
        offset = frame.glyph * 1.1
        frame.surface.blit(label, (round(x + offset), round(y - offset - label.get_height() / 2)))
