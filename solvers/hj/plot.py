"""2-D slices of reach-avoid tubes (the paper's Fig. 2) with matplotlib (no pyplot state).

A slice fixes every player but one and shades the free player's positions from which the
attacker side wins (value <= 0). Players are named as in the game's declaration (``"A"``
and ``"D"`` in 1 vs 1, ``"A1"``, ``"A2"`` and ``"D"`` in 2 vs 1, ``"D1"``, ``"D2"`` and
``"A"`` in 1 vs 2). Colours and glyphs are the videos' (``reachavoid_env.palette``: red
triangles attack, blue squares defend, the target is yellow); ``tube_figure`` puts a legend
under the panels that says so.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib import patches
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from reachavoid_env import GameMap
from reachavoid_env import palette as P
from reachavoid_env.files import atomic_write
from solvers.hj.value import ValueFunction

Point = tuple[float, float]


def players(vf: ValueFunction) -> tuple[str, ...]:
    """Player names of the game, in axis order."""
    return tuple(p.name for p in vf.players)


def slice_values(vf: ValueFunction, free: str, fixed: Mapping[str, Point],
                 resolution: int = 200) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Values over the free player's plane: ``(xs, ys, value[iy, ix])``."""
    names = players(vf)
    if free not in names:
        raise ValueError(f"free: expected one of {names}, got {free!r}")
    missing = set(names) - {free} - set(fixed)
    if missing:
        raise ValueError(f"fixed: positions missing for {sorted(missing)}")
    xmin, xmax, ymin, ymax = vf.game_map.domain
    xs, ys = np.linspace(xmin, xmax, resolution), np.linspace(ymin, ymax, resolution)
    gx, gy = np.meshgrid(xs, ys)
    states = np.empty((resolution * resolution, vf.grid.ndim))
    for k, name in enumerate(names):
        if name == free:
            states[:, 2 * k], states[:, 2 * k + 1] = gx.ravel(), gy.ravel()
        else:
            states[:, 2 * k:2 * k + 2] = np.asarray(fixed[name], dtype=np.float64)
    return xs, ys, vf.value(states).reshape(resolution, resolution)


MARKERS = {"attacker": "^", "defender": "s"}
"""The glyph of each role, as in the videos."""


def draw_map(ax: Axes, game_map: GameMap) -> None:
    """Obstacles (grey), target (yellow) and the domain's outline, as in the videos."""
    xmin, xmax, ymin, ymax = game_map.domain
    ax.add_patch(patches.Rectangle((xmin, ymin), xmax - xmin, ymax - ymin, fill=False,
                                   edgecolor=P.unit(P.BORDER), linewidth=1.0))
    for shape in game_map.obstacles:
        ax.add_patch(patches.Polygon(shape.outline(), closed=True,
                                     facecolor=P.unit(P.OBSTACLE),
                                     edgecolor=P.unit(P.OBSTACLE), zorder=3))
    for shape in game_map.target:
        ax.add_patch(patches.Polygon(shape.outline(), closed=True, facecolor=P.unit(P.TARGET),
                                     edgecolor=P.unit(P.TARGET_EDGE), zorder=3))
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)
    ax.set_aspect("equal")


def plot_slice(vf: ValueFunction, free: str, fixed: Mapping[str, Point], ax: Axes | None = None,
               resolution: int = 200, title: str | None = None) -> Axes:
    """Shade where the attacker side wins as ``free`` moves, the others held at ``fixed``."""
    if ax is None:
        ax = Figure(figsize=(5, 5)).subplots()
    xs, ys, value = slice_values(vf, free, fixed, resolution)
    ax.contourf(xs, ys, value, levels=[value.min() - 1.0, 0.0],
                colors=[P.unit(P.ATTACKER_WINS)])
    ax.contour(xs, ys, value, levels=[0.0], colors=[P.unit(P.ATTACKER)], linewidths=1.2)
    draw_map(ax, vf.game_map)
    roles = {p.name: p.role for p in vf.players}
    for name, (x, y) in fixed.items():
        color = P.unit(P.DEFENDER if roles[name] == "defender" else P.ATTACKER)
        ax.plot(x, y, marker=MARKERS[roles[name]], color=color, markeredgecolor="black",
                markersize=8, zorder=5)
        ax.annotate(name, (x, y), textcoords="offset points", xytext=(6, 6), zorder=5,
                    color=color, fontweight="bold")
        if roles[name] == "defender":
            ax.add_patch(patches.Circle((x, y), vf.capture_radius, fill=False,
                                        edgecolor=color, linestyle="--", zorder=5))
    fixed_text = ", ".join(f"{n}=({x:g}, {y:g})" for n, (x, y) in fixed.items())
    ax.set_title(title or f"{vf.game}, {free} free: red where the attackers win with {free} "
                          f"there\n{fixed_text}", fontsize=9)
    return ax


def legend_handles() -> list[Line2D | patches.Patch]:
    """What the colours and glyphs of a tube slice mean (the videos' palette)."""
    return [
        patches.Patch(facecolor=P.unit(P.ATTACKER_WINS), edgecolor=P.unit(P.ATTACKER),
                      label="attackers win with the free player here (value <= 0)"),
        Line2D([], [], color=P.unit(P.ATTACKER), label="value = 0: the tube's boundary"),
        patches.Patch(facecolor=P.unit(P.TARGET), edgecolor=P.unit(P.TARGET_EDGE),
                      label="target"),
        patches.Patch(facecolor=P.unit(P.OBSTACLE), label="obstacle"),
        Line2D([], [], linestyle="", marker=MARKERS["attacker"], color=P.unit(P.ATTACKER),
               markeredgecolor="black", markersize=8, label="attacker (held fixed)"),
        Line2D([], [], linestyle="", marker=MARKERS["defender"], color=P.unit(P.DEFENDER),
               markeredgecolor="black", markersize=8, label="defender (held fixed)"),
        Line2D([], [], linestyle="--", color=P.unit(P.DEFENDER), label="capture disc"),
    ]


def tube_figure(panels: Sequence[tuple[ValueFunction, str, Mapping[str, Point]]],
                path: str | os.PathLike[str] | None = None) -> Figure:
    """One panel per ``(value function, free player, fixed players)`` and the legend under
    them; saved as PNG to ``path`` when given (temporary name, then renamed)."""
    figure = Figure(figsize=(4.6 * len(panels), 5.6), layout="constrained")
    axes = figure.subplots(1, len(panels), squeeze=False)
    for ax, (vf, free, fixed) in zip(axes[0], panels, strict=True):
        plot_slice(vf, free, fixed, ax=ax)
    figure.legend(handles=legend_handles(), loc="outside lower center",
                  ncols=min(len(legend_handles()), 2 * len(panels)), fontsize=9,
                  frameon=False)
    if path is not None:
        save_figure(figure, path)
    return figure


def scenario_panels(vf: ValueFunction, attackers: Sequence[Point], defenders: Sequence[Point]
                    ) -> list[tuple[ValueFunction, str, dict[str, Point]]]:
    """The paper's Fig. 2 slices at given starts, for any game: the last attacker free
    (everyone else fixed) and the first defender free. 1 vs 1: A free, then D free; 2 vs 1:
    A2 free (A1 and D fixed), then D free (both attackers fixed); 1 vs 2: A free (both
    defenders fixed), then D1 free (D2 and A fixed)."""
    names = {"attacker": [p.name for p in vf.attackers],
             "defender": [p.name for p in vf.defenders]}
    given = {"attacker": list(attackers), "defender": list(defenders)}
    for role in names:
        if len(given[role]) < len(names[role]):
            raise ValueError(f"{role}s: the {vf.game} slices need {len(names[role])} {role} "
                             "positions")
    position = {name: tuple(given[role][k]) for role in names
                for k, name in enumerate(names[role])}
    return [(vf, free, {n: p for n, p in position.items() if n != free})
            for free in (names["attacker"][-1], names["defender"][0])]


def save_figure(figure: Figure, path: str | os.PathLike[str]) -> Path:
    """Save ``figure`` as PNG through ``atomic_write`` (a temporary name of its own, then
    renamed), so two processes saving the same figure never collide."""
    with atomic_write(path, "wb") as handle:
        figure.savefig(handle, dpi=120, format="png")
    return Path(path)
