"""What the renderer (``render``) draws over the map and around it: a policy's
``Overlay`` edges, each kind in its own style (``EDGE_STYLES``) and along its route where
it has one; the header (the title, the clock, the overlay's text lines); on the last frame
of an episode, a banner saying how it ended.
"""

from __future__ import annotations

import os
from typing import NamedTuple

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np  # noqa: E402
import pygame  # noqa: E402

from reachavoid_env import palette as P  # noqa: E402
from reachavoid_env.game_state import AttackerStatus, GameState  # noqa: E402
from reachavoid_env.overlay import EdgeKind, Overlay, outcome_line  # noqa: E402
from reachavoid_env.render_frame import Frame  # noqa: E402


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


class Edges:
    """An overlay's defender-attacker edges, on a white halo (readable over obstacles and
    trails)."""

    def __init__(self, frame: Frame) -> None:
        self.frame = frame

    def draw_all(self, overlay: Overlay, state: GameState, attackers: np.ndarray,
                 defenders: np.ndarray) -> None:
        """``overlay``'s edges to attackers still in play in ``state``, from ``defenders``
        ``(N, 2)`` to ``attackers`` ``(M, 2)`` pixels (through an edge's route's points).

        Raises:
            ValueError: an edge names a player that ``state`` does not have.
        """
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
            between = self.frame.to_pixels(
                np.array(route[1:-1], dtype=np.float64).reshape(-1, 2))
            self.draw(kind, np.concatenate([defenders[defender_index[defender]][None],
                                            between, attackers[i][None]]))

    def draw(self, kind: EdgeKind, pixels: np.ndarray) -> None:
        """A line in ``kind``'s style, its dashes running on from segment to segment.

        Args:
            kind: the edge's kind (``EDGE_STYLES``): dashes of ``dash`` pixels every
                ``dash + gap`` pixels along the line, both times ``Frame.unit``.
            pixels: ``(K, 2)`` (K >= 2) the points the line runs through.
        """
        frame = self.frame
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
            dash, period = style.dash * frame.unit, (style.dash + style.gap) * frame.unit
            pieces = [(a, min(a + dash, length)) for a in np.arange(0.0, length, period).tolist()]
        runs = [[at(a)] + [tuple(p) for p in pixels[1:-1][(starts[1:-1] > a)
                                                        & (starts[1:-1] < b)].tolist()]
                + [at(b)] for a, b in pieces]
        for color, width in ((P.HALO, frame.edge_width + 2 * max(1, round(frame.unit))),
                             (style.color, frame.edge_width)):
            for run in runs:
                for start, end in zip(run, run[1:], strict=False):
                    pygame.draw.line(frame.surface, color, start, end, width)


class Captions:
    """The words over the map: the header and the outcome banner."""

    def __init__(self, frame: Frame) -> None:
        self.frame = frame

    def draw_header(self, state: GameState, overlay: Overlay | None, title: str) -> None:
        """The title, the clock, then the overlay's text lines (at most
        ``Frame.text_lines`` of them)."""
        frame = self.frame
        pad, room = frame.margin, frame.width - 2 * frame.margin
        top = round(frame.margin / 2)
        if title:
            words = frame.text(frame.fit(title, room, frame.title_font), P.TEXT,
                               frame.title_font)
            frame.surface.blit(words, (pad, top))
        top += frame.title_font.get_linesize()
        clock = frame.font.render(f"t = {state.time:.3f} s   step {state.step}", True, P.TEXT)
        frame.surface.blit(clock, (pad, top))
        lines = list(overlay.lines) if overlay is not None else []
        if len(lines) > frame.text_lines:
            lines = lines[:frame.text_lines]
            if lines:  # no room for text (text_lines=0): none drawn
                lines[-1] += " ..."
        for k, line in enumerate(lines, start=1):
            text = frame.text(frame.fit(line, room), P.TEXT_DIM, frame.font)
            frame.surface.blit(text, (pad, top + k * frame.line_height))

    def draw_banner(self, state: GameState) -> None:
        """How the episode ended, in a box across the top of the map: the words wrapped to
        the map's width less four margins; the box as wide as the widest line plus two
        margins, a line pitch per line plus a margin high, a margin below the map's top.

        Args:
            state: the episode's last state.
        """
        frame = self.frame
        total, arrived = len(state.attacker_status), len(state.arrived)
        field = frame.field()
        room = field.width - 4 * frame.margin
        lines = [""]
        for word in outcome_line(total, len(state.captured), arrived).split(" "):
            longer = f"{lines[-1]} {word}".strip()
            if lines[-1] and frame.banner_font.size(longer)[0] > room:
                lines.append(word)
            else:
                lines[-1] = longer
        texts = [frame.text(frame.fit(line, room, frame.banner_font), P.TEXT,
                            frame.banner_font) for line in lines]
        pitch = frame.banner_font.get_linesize()
        box = pygame.Rect(0, 0, max(t.get_width() for t in texts) + 2 * frame.margin,
                          pitch * len(texts) + frame.margin)
        box.midtop = (field.centerx, field.top + frame.margin)
        panel = pygame.Surface(box.size, pygame.SRCALPHA)
        panel.fill((*P.HALO, 230))
        frame.surface.blit(panel, box.topleft)
        edge = P.ATTACKER if arrived else P.DEFENDER
        pygame.draw.rect(frame.surface, edge, box, width=max(2, round(3 * frame.unit)))
        for k, text in enumerate(texts):
            frame.surface.blit(text, text.get_rect(midtop=(box.centerx, box.top
                                                            + frame.margin // 2 + k * pitch)))
