"""The one palette of the project: every frame (``render``) and every figure (the tube
slices of ``solvers.hj.plot``) draws with these colours, so that a colour means the same
thing in a video and in a figure: red is the attackers' side, blue the defenders', yellow
the target, grey an obstacle.

Colours are ``(red, green, blue)`` integers in 0..255 (pygame's form); ``unit`` gives
matplotlib's form.
"""

from __future__ import annotations

Color = tuple[int, int, int]

FRAME: Color = (226, 229, 234)        # around the map, behind the header and the legend
FIELD: Color = (255, 255, 255)        # the free part of the domain
BORDER: Color = (60, 64, 72)          # the domain's outline
OBSTACLE: Color = (92, 96, 106)
TARGET: Color = (252, 222, 128)
TARGET_EDGE: Color = (196, 150, 30)
ATTACKER: Color = (214, 39, 40)
ATTACKER_WINS: Color = (255, 152, 150)  # tube figures: where the attacker side wins
DEFENDER: Color = (31, 90, 200)
CAPTURED: Color = (40, 40, 40)
EDGE: Color = (20, 150, 55)           # an assignment edge: one defender, one attacker (1 vs 1)
PAIR_EDGE: Color = (235, 120, 0)      # one defender on two attackers (a 2 vs 1 game)
TEAM_EDGE: Color = (150, 60, 200)     # two defenders on one attacker (a 1 vs 2 game)
RACE_EDGE: Color = (90, 110, 130)     # a defender racing to intercept, in no certified game
TEXT: Color = (30, 32, 38)
TEXT_DIM: Color = (80, 86, 98)
HALO: Color = (255, 255, 255)         # the outline that keeps text readable over anything


def unit(color: Color) -> tuple[float, float, float]:
    """``color`` as matplotlib's ``(r, g, b)`` floats in [0, 1]."""
    return tuple(c / 255 for c in color)


def blend(color: Color, toward: Color, amount: float) -> Color:
    """``color`` moved ``amount`` (0..1) of the way to ``toward``."""
    return tuple(round(c + (t - c) * amount) for c, t in zip(color, toward, strict=True))
