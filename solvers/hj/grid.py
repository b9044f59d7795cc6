"""Regular Cartesian grids: node coordinates and multilinear interpolation.

Nodes include both ends of every axis, as ``numpy.linspace(lo, hi, n)``. Coordinates are
map units. Values live in C-order float32 arrays of the grid's ``shape``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

_WHOLE = np.zeros(1, dtype=np.int64)
"""``stored_of`` of an array held whole, as one row."""


@dataclass(frozen=True)
class Grid:
    """Axis-aligned grid with ``shape[k]`` nodes from ``lo[k]`` to ``hi[k]`` on axis ``k``."""

    lo: tuple[float, ...]
    hi: tuple[float, ...]
    shape: tuple[int, ...]

    def __post_init__(self) -> None:
        lo = tuple(float(v) for v in self.lo)
        hi = tuple(float(v) for v in self.hi)
        shape = tuple(int(n) for n in self.shape)
        if not (len(lo) == len(hi) == len(shape)) or not shape:
            raise ValueError(f"grid: lo, hi and shape need the same positive length, got "
                             f"{len(lo)}, {len(hi)}, {len(shape)}")
        for k, (a, b, n) in enumerate(zip(lo, hi, shape, strict=True)):
            if not b > a:
                raise ValueError(f"grid axis {k}: need lo < hi, got [{a}, {b}]")
            if n < 3:
                raise ValueError(f"grid axis {k}: need at least 3 nodes, got {n}")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)
        object.__setattr__(self, "shape", shape)

    @classmethod
    def for_players(cls, domain: Sequence[float], players: int,
                    points: int | Sequence[int]) -> Grid:
        """The joint grid of ``players`` planar players over ``domain = (xmin, xmax, ymin, ymax)``.

        ``points`` is the node count per axis (one number, or one per axis).
        """
        xmin, xmax, ymin, ymax = (float(v) for v in domain)
        ndim = 2 * players
        shape = (points,) * ndim if isinstance(points, (int, np.integer)) else tuple(points)
        if len(shape) != ndim:
            raise ValueError(f"grid_points: expected one count or {ndim}, got {len(shape)}")
        return cls((xmin, ymin) * players, (xmax, ymax) * players, shape)

    @property
    def ndim(self) -> int:
        return len(self.shape)

    @property
    def size(self) -> int:
        """Number of nodes."""
        return int(np.prod(self.shape, dtype=np.int64))

    @cached_property
    def spacing(self) -> tuple[float, ...]:
        """Distance between neighbouring nodes on each axis (map units)."""
        return tuple((b - a) / (n - 1) for a, b, n in zip(self.lo, self.hi, self.shape,
                                                          strict=True))

    def coordinates(self, axis: int) -> np.ndarray:
        """Node coordinates along ``axis`` (float64)."""
        return np.linspace(self.lo[axis], self.hi[axis], self.shape[axis])

    def sub(self, axes: Sequence[int]) -> Grid:
        """The grid of the given axes only."""
        return Grid(tuple(self.lo[k] for k in axes), tuple(self.hi[k] for k in axes),
                    tuple(self.shape[k] for k in axes))

    def points(self, index: np.ndarray) -> np.ndarray:
        """Coordinates ``(..., ndim)`` of integer node indices ``(..., ndim)``."""
        index = np.asarray(index)
        return np.asarray(self.lo) + index * np.asarray(self.spacing)

    def nearest_index(self, points: np.ndarray) -> np.ndarray:
        """Index ``(K, ndim)`` of the nearest node to each of ``points (K, ndim)``, clipped
        into the grid."""
        points = self._points(points)
        index = np.rint((points - np.asarray(self.lo)) / np.asarray(self.spacing))
        return np.clip(index, 0, np.asarray(self.shape) - 1).astype(np.int64)

    def mesh(self) -> np.ndarray:
        """All node coordinates, shape ``shape + (ndim,)`` (for small grids)."""
        axes = [self.coordinates(k) for k in range(self.ndim)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)

    def interpolate(self, values: np.ndarray, points: np.ndarray,
                    stored_of: np.ndarray | None = None) -> np.ndarray:
        """Multilinear interpolation of nodal ``values`` at ``points (K, ndim)`` -> ``(K,)``.

        Points outside the grid are clamped onto its boundary. ``values`` has the grid's
        shape, or with ``stored_of`` is stored as rows (``layout.Layout``).
        """
        from solvers.hj import kernels  # numba loads when a tube is first read

        rows, stored_of = self._values(values, stored_of)
        return kernels.interpolate(rows, stored_of, *self.kernel_arrays, self._points(points))

    def interpolate_gradient(self, values: np.ndarray, points: np.ndarray,
                             stored_of: np.ndarray | None = None,
                             axes: np.ndarray | None = None) -> np.ndarray:
        """Gradient at ``points (K, ndim)`` -> ``(K, ndim)``: nodal central differences
        (one-sided on the grid's edges), interpolated multilinearly. Units: value per map unit.
        With ``axes`` (int64 axis numbers) only those components, ``(K, len(axes))``.
        """
        from solvers.hj import kernels

        rows, stored_of = self._values(values, stored_of)
        return kernels.interpolate_gradient(rows, stored_of, *self.kernel_arrays,
                                            self._points(points), self._axes(axes))

    def interpolate_with_gradient(self, values: np.ndarray, points: np.ndarray,
                                  stored_of: np.ndarray | None = None,
                                  axes: np.ndarray | None = None
                                  ) -> tuple[np.ndarray, np.ndarray]:
        """``interpolate`` and ``interpolate_gradient`` at once, in one pass over each
        point's cell: ``((K,), (K, ndim))`` (or ``(K, len(axes))``), equal to the two
        calls' results."""
        from solvers.hj import kernels

        rows, stored_of = self._values(values, stored_of)
        return kernels.interpolate_with_gradient(rows, stored_of, *self.kernel_arrays,
                                                 self._points(points), self._axes(axes))

    @cached_property
    def _all_axes(self) -> np.ndarray:
        return np.arange(self.ndim, dtype=np.int64)

    def _axes(self, axes: np.ndarray | None) -> np.ndarray:
        if axes is None:
            return self._all_axes
        axes = np.asarray(axes)
        if (axes.ndim != 1 or axes.dtype != np.int64 or axes.size == 0
                or axes.min() < 0 or axes.max() >= self.ndim):
            raise ValueError(f"axes: expected int64 axis numbers in 0..{self.ndim - 1}, got "
                             f"{axes!r}")
        return axes

    @cached_property
    def kernel_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``shape`` (int64), ``lo`` and ``spacing`` (float64) as the kernels take them
        (made once; not to be written to)."""
        return (np.asarray(self.shape, dtype=np.int64), np.asarray(self.lo, dtype=np.float64),
                np.asarray(self.spacing, dtype=np.float64))

    def _values(self, values: np.ndarray,
                stored_of: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        if values.dtype != np.float32 or not values.flags.c_contiguous:
            raise ValueError("values: expected a C-contiguous float32 array")
        if stored_of is not None:
            return values, stored_of
        if tuple(values.shape) != self.shape:
            raise ValueError(f"values: shape {tuple(values.shape)} does not match the grid "
                             f"{self.shape}")
        return values.reshape(1, -1), _WHOLE

    def _points(self, points: np.ndarray) -> np.ndarray:
        points = np.ascontiguousarray(points, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != self.ndim:
            raise ValueError(f"points: expected shape (K, {self.ndim}), got {points.shape}")
        if not np.isfinite(points).all():
            raise ValueError("points: contain NaN or inf")
        return points
