"""Numba kernels of the reach-avoid solver (the game-independent parts) and interpolation.

Every kernel takes plain arrays; ``tests/kernels_reference.py`` holds a slow numpy twin of each.

Row layout (``layout``): a game's value is held as a 2-D float32 array ``(rows, m)``. The
last player's plane is a row: its two axes flattened into ``m = nx * ny`` contiguous
elements. Each configuration of the other players (the "row players") is one row; under
exchange symmetry only the canonical configurations are stored and ``stored_of`` maps
every configuration to the row that holds it. Differences along the last player's axes
are taken inside a row, differences along a row player's axis compare a row with its
neighbouring rows. Each pass over a row's ``m`` elements is short and branch-free so that
LLVM vectorises it; no signed offset is added to an element index (row views instead).

Schemes (``schemes``): the numerical Hamiltonian is a sum over players,
``H = sum_attackers -v |p| + sum_defenders v |p|``; a piece adds one player's term to
``ham`` and raises ``jump`` (the largest jump to a stencil neighbour, for the convergence
measure). Spatial derivatives use a zero-gradient boundary (a missing neighbour is the
node itself, ``width`` nodes deep). First order, per axis with raw one-sided differences
``f+ = u[i+1] - u[i]`` and ``f- = u[i] - u[i-1]``:
- Godunov: a maximiser's ``|p|`` is ``sqrt(sum_axes max(f+, -f-, 0)^2 / h^2)``, a
  minimiser's ``sqrt(sum_axes max(-f+, f-, 0)^2 / h^2)``;
- Lax-Friedrichs: ``|p|`` of the central difference, plus the dissipation
  ``speed * (f+ - f-) / (2 h)`` per axis;
- ENO2 (second order, Godunov's upwinding of the ENO2 one-sided derivatives
  ``D+- = f+- / h -+ minmod(second differences) / (2 h)``, two nodes deep).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from reachavoid_env.jit_cache import check_numba_config

check_numba_config()   # numba loads pickled code: only from a folder of ours

FASTMATH = {"nnan", "ninf", "nsz", "reassoc", "contract"}
_ZERO = np.float32(0.0)
_HALF = np.float32(0.5)


# ---------------------------------------------------------------------------------------
# rows and their neighbours
# ---------------------------------------------------------------------------------------

@njit(cache=True)
def neighbour_rows(row, row_nodes, row_shape, row_stride, stored_of, width, out):
    """``out[k, axis, j]``: the stored row ``offset`` nodes away from ``row`` along axis
    ``axis`` (0: x, 1: y) of row player ``k``, offsets ``-width..-1, 1..width`` in order of
    ``j``, clamped into the grid (zero-gradient boundary: the row itself at the edge)."""
    players = row_nodes.shape[1]
    full = 0
    for k in range(players):
        full += row_nodes[row, k] * row_stride[k]
    for k in range(players):
        nx = row_shape[k, 0]
        ny = row_shape[k, 1]
        node = row_nodes[row, k]
        ix = node // ny
        iy = node % ny
        for j in range(2 * width):
            offset = j - width if j < width else j - width + 1
            jx = min(max(ix + offset, 0), nx - 1)
            jy = min(max(iy + offset, 0), ny - 1)
            out[k, 0, j] = stored_of[full + (jx - ix) * ny * row_stride[k]]
            out[k, 1, j] = stored_of[full + (jy - iy) * row_stride[k]]


@njit(cache=True, fastmath=FASTMATH)
def in_row_differences(row, ny, fx, fy):
    """Raw forward differences of a row along the last player's two in-row axes.

    ``fx`` (length ``m + 3 ny``) and ``fy`` (length ``m + 3``) are padded so that at element
    ``r`` the forward difference from node ``r + k`` steps ahead is ``fx[(2 + k) ny + r]`` /
    ``fy[2 + k + r]`` for ``k`` in ``-2..1``; differences across the grid's edge are zero.
    """
    m = row.size
    for r in range(2 * ny):
        fx[r] = _ZERO
    for r in range(ny):
        fx[m + 2 * ny + r] = _ZERO
    ahead_x = row[ny:]
    out_x = fx[2 * ny:]
    for r in range(m - ny):
        out_x[r] = ahead_x[r] - row[r]
    for r in range(m - ny, m):
        out_x[r] = _ZERO
    fy[0] = _ZERO
    fy[1] = _ZERO
    fy[m + 2] = _ZERO
    ahead_y = row[1:]
    out_y = fy[2:]
    for r in range(m - 1):
        out_y[r] = ahead_y[r] - row[r]
    for r in range(ny - 1, m, ny):
        out_y[r] = _ZERO


# ---------------------------------------------------------------------------------------
# first-order pieces
# ---------------------------------------------------------------------------------------

@njit(cache=True)
def _in_row_views(fx, fy, ny):
    """Forward and backward raw differences at every element (``in_row_differences``)."""
    return fx[2 * ny:], fx[ny:], fy[2:], fy[1:]


@njit(cache=True, fastmath=FASTMATH)
def godunov_in_row(row, ny, fx, fy, inv_hx, inv_hy, speed, maximise, ham, jump):
    """Set ``ham`` to the last player's Godunov term and ``jump`` to the in-row jumps (the
    first piece of a row, after ``in_row_differences``)."""
    m = ham.size
    fxp, fxm, fyp, fym = _in_row_views(fx, fy, ny)
    sign = np.float32(1.0) if maximise else np.float32(-1.0)
    for r in range(m):
        qx = max(max(sign * fxp[r], -sign * fxm[r]), _ZERO) * inv_hx
        qy = max(max(sign * fyp[r], -sign * fym[r]), _ZERO) * inv_hy
        ham[r] = sign * speed * np.sqrt(qx * qx + qy * qy)
        jump[r] = max(max(abs(fxp[r]), abs(fxm[r])), max(abs(fyp[r]), abs(fym[r])))


@njit(cache=True, fastmath=FASTMATH)
def lax_friedrichs_in_row(row, ny, fx, fy, inv_hx, inv_hy, speed, maximise, ham, jump):
    """Set ``ham`` and ``jump``: the last player's Lax-Friedrichs term (as ``godunov_in_row``)."""
    m = ham.size
    fxp, fxm, fyp, fym = _in_row_views(fx, fy, ny)
    sign = np.float32(1.0) if maximise else np.float32(-1.0)
    for r in range(m):
        cx = (fxp[r] + fxm[r]) * (_HALF * inv_hx)
        cy = (fyp[r] + fym[r]) * (_HALF * inv_hy)
        diss = (fxp[r] - fxm[r]) * inv_hx + (fyp[r] - fym[r]) * inv_hy
        ham[r] = speed * (sign * np.sqrt(cx * cx + cy * cy) + _HALF * diss)
        jump[r] = max(max(abs(fxp[r]), abs(fxm[r])), max(abs(fyp[r]), abs(fym[r])))


@njit(cache=True, fastmath=FASTMATH)
def godunov_across(row, values, nbr, inv_hx, inv_hy, speed, maximise, ham, jump):
    """Add a row player's Godunov term; ``nbr`` = ``neighbour_rows`` of that player
    (width 1: ``[axis, (minus, plus)]``)."""
    xm, xp = values[nbr[0, 0]], values[nbr[0, 1]]
    ym, yp = values[nbr[1, 0]], values[nbr[1, 1]]
    m = ham.size
    if maximise:
        for r in range(m):
            v = row[r]
            qx = max(max(xp[r], xm[r]) - v, _ZERO) * inv_hx
            qy = max(max(yp[r], ym[r]) - v, _ZERO) * inv_hy
            ham[r] += speed * np.sqrt(qx * qx + qy * qy)
            big = max(max(abs(xp[r] - v), abs(xm[r] - v)), max(abs(yp[r] - v), abs(ym[r] - v)))
            jump[r] = max(jump[r], big)
    else:
        for r in range(m):
            v = row[r]
            qx = max(v - min(xp[r], xm[r]), _ZERO) * inv_hx
            qy = max(v - min(yp[r], ym[r]), _ZERO) * inv_hy
            ham[r] -= speed * np.sqrt(qx * qx + qy * qy)
            big = max(max(abs(xp[r] - v), abs(xm[r] - v)), max(abs(yp[r] - v), abs(ym[r] - v)))
            jump[r] = max(jump[r], big)


@njit(cache=True, fastmath=FASTMATH)
def lax_friedrichs_across(row, values, nbr, inv_hx, inv_hy, speed, maximise, ham, jump):
    """Add a row player's Lax-Friedrichs term (``nbr`` as in ``godunov_across``)."""
    xm, xp = values[nbr[0, 0]], values[nbr[0, 1]]
    ym, yp = values[nbr[1, 0]], values[nbr[1, 1]]
    sign = np.float32(1.0) if maximise else np.float32(-1.0)
    m = ham.size
    for r in range(m):
        v = row[r]
        cx = (xp[r] - xm[r]) * (_HALF * inv_hx)
        cy = (yp[r] - ym[r]) * (_HALF * inv_hy)
        diss = (xp[r] + xm[r] - v - v) * inv_hx + (yp[r] + ym[r] - v - v) * inv_hy
        ham[r] += speed * (sign * np.sqrt(cx * cx + cy * cy) + _HALF * diss)
        big = max(max(abs(xp[r] - v), abs(xm[r] - v)), max(abs(yp[r] - v), abs(ym[r] - v)))
        jump[r] = max(jump[r], big)


# ---------------------------------------------------------------------------------------
# second order: ENO2
# ---------------------------------------------------------------------------------------

@njit(cache=True, fastmath=FASTMATH)
def _minmod(a, b):
    return _HALF * (np.sign(a) + np.sign(b)) * min(abs(a), abs(b))


@njit(cache=True, fastmath=FASTMATH)
def _eno2_upwind(f_mm, f_m, f_p, f_pp, maximise):
    """Upwinded raw difference (times h) of one axis from the forward differences
    ``u[i-1]-u[i-2], u[i]-u[i-1], u[i+1]-u[i], u[i+2]-u[i+1]``."""
    centre = f_p - f_m
    plus = f_p - _HALF * _minmod(centre, f_pp - f_p)
    minus = f_m + _HALF * _minmod(centre, f_m - f_mm)
    if maximise:
        return max(max(plus, -minus), _ZERO)
    return max(max(-plus, minus), _ZERO)


@njit(cache=True, fastmath=FASTMATH)
def eno2_in_row(row, ny, fx, fy, inv_hx, inv_hy, speed, maximise, ham, jump):
    """Set ``ham`` and ``jump``: the last player's ENO2 term (as ``godunov_in_row``)."""
    m = ham.size
    fx_mm, fx_m, fx_p, fx_pp = fx[:m], fx[ny:], fx[2 * ny:], fx[3 * ny:]
    fy_mm, fy_m, fy_p, fy_pp = fy[:m], fy[1:], fy[2:], fy[3:]
    sign = np.float32(1.0) if maximise else np.float32(-1.0)
    for ix in range(m // ny):
        for iy in range(ny):
            r = ix * ny + iy
            # two nodes deep across a y edge the padding holds the next x line's values
            y_mm = fy_mm[r] if iy > 0 else _ZERO
            y_pp = fy_pp[r] if iy < ny - 1 else _ZERO
            qx = _eno2_upwind(fx_mm[r], fx_m[r], fx_p[r], fx_pp[r], maximise) * inv_hx
            qy = _eno2_upwind(y_mm, fy_m[r], fy_p[r], y_pp, maximise) * inv_hy
            ham[r] = sign * speed * np.sqrt(qx * qx + qy * qy)
            jump[r] = max(max(abs(fx_p[r]), abs(fx_m[r])), max(abs(fy_p[r]), abs(fy_m[r])))


@njit(cache=True, fastmath=FASTMATH)
def eno2_across(row, values, nbr, inv_hx, inv_hy, speed, maximise, ham, jump):
    """Add a row player's ENO2 term; ``nbr`` of width 2: ``[axis, (-2, -1, +1, +2)]``."""
    xmm, xm, xp, xpp = values[nbr[0, 0]], values[nbr[0, 1]], values[nbr[0, 2]], values[nbr[0, 3]]
    ymm, ym, yp, ypp = values[nbr[1, 0]], values[nbr[1, 1]], values[nbr[1, 2]], values[nbr[1, 3]]
    sign = np.float32(1.0) if maximise else np.float32(-1.0)
    m = ham.size
    for r in range(m):
        v = row[r]
        qx = _eno2_upwind(xm[r] - xmm[r], v - xm[r], xp[r] - v, xpp[r] - xp[r],
                          maximise) * inv_hx
        qy = _eno2_upwind(ym[r] - ymm[r], v - ym[r], yp[r] - v, ypp[r] - yp[r],
                          maximise) * inv_hy
        ham[r] += sign * speed * np.sqrt(qx * qx + qy * qy)
        big = max(max(abs(xp[r] - v), abs(xm[r] - v)), max(abs(yp[r] - v), abs(ym[r] - v)))
        jump[r] = max(jump[r], big)


# ---------------------------------------------------------------------------------------
# warm starts
# ---------------------------------------------------------------------------------------

@njit(cache=True, parallel=True)
def interpolate_rows(coarse, coarse_stored_of, coarse_shape, coarse_stride, lo, spacing,
                     points, margin, out):
    """``out[k] = margin + sum_corners w * coarse[stored_of[corner row]]``: the coarse rows
    (already interpolated onto the fine plane) multilinearly interpolated at the row
    players' coordinates ``points[k]`` (``(rows, 2 P)``), clamped into the coarse grid.

    ``coarse_shape`` ``(2 P,)`` node counts of the coarse row axes, ``coarse_stride``
    ``(2 P,)`` their strides in coarse (full) row numbers, ``lo``/``spacing`` the coarse
    row axes' grid."""
    axes = coarse_shape.size
    m = out.shape[1]
    for k in prange(points.shape[0]):
        frac = np.empty(axes, dtype=np.float64)
        base = 0
        for a in range(axes):
            i, t = _cell(points[k, a], lo[a], spacing[a], coarse_shape[a])
            base += i * coarse_stride[a]
            frac[a] = t
        target = out[k]
        for r in range(m):
            target[r] = margin
        for corner in range(1 << axes):
            weight, offset = _corner(corner, base, frac, coarse_stride)
            if weight != 0.0:
                source = coarse[coarse_stored_of[offset]]
                w = np.float32(weight)
                for r in range(m):
                    target[r] += w * source[r]


# ---------------------------------------------------------------------------------------
# interpolation (values stored as rows: ``values[stored_of[flat // m], flat % m]``)
# ---------------------------------------------------------------------------------------
# The per-point helpers (``row_strides``, ``corner_offsets``, ``locate_cell``,
# ``value_at``, ``gradient_point``) are public: ``policies.lookups`` builds its batched
# decision kernels from them, so its values are those of ``ValueFunction`` bit for bit.

@njit(cache=True)
def _cell(x, lo, h, n):
    """Lower node index and fraction of coordinate ``x`` on an axis, clamped into the grid."""
    s = (x - lo) / h
    if s <= 0.0:
        return 0, 0.0
    if s >= n - 1:
        return n - 2, 1.0
    i = min(int(s), n - 2)
    return i, s - i


@njit(cache=True)
def _corner(corner, base, frac, strides):
    """Weight and flat index of one corner (bit ``k`` of ``corner``: upper node on axis k)."""
    weight = 1.0
    offset = base
    for k in range(frac.size):
        if (corner >> k) & 1:
            weight *= frac[k]
            offset += strides[k]
        else:
            weight *= 1.0 - frac[k]
    return weight, offset


@njit(cache=True)
def row_strides(shape, m):
    """Strides of each axis in rows and in a row's elements (the other one zero) when the
    trailing axes that make up a row hold ``m`` elements, C order."""
    ndim = shape.size
    row_stride = np.zeros(ndim, dtype=np.int64)
    col_stride = np.zeros(ndim, dtype=np.int64)
    s = 1
    for k in range(ndim - 1, -1, -1):
        if s < m:
            col_stride[k] = s
        else:
            row_stride[k] = s // m
        s *= shape[k]
        if s > m and s // shape[k] < m:
            raise ValueError("values: the rows do not hold whole trailing axes of the grid")
    if s < m:
        raise ValueError("values: the rows do not hold whole trailing axes of the grid")
    return row_stride, col_stride


@njit(cache=True)
def corner_offsets(row_stride, col_stride):
    """Row and element offsets of every cell corner from its lowest corner (bit ``k`` of
    the corner number: the upper node on axis ``k``)."""
    ndim = row_stride.size
    rows = np.zeros(1 << ndim, dtype=np.int64)
    cols = np.zeros(1 << ndim, dtype=np.int64)
    for corner in range(1 << ndim):
        for k in range(ndim):
            if (corner >> k) & 1:
                rows[corner] += row_stride[k]
                cols[corner] += col_stride[k]
    return rows, cols


@njit(cache=True)
def locate_cell(point, shape, lo, spacing, row_stride, col_stride, lower, weights):
    """Lowest corner ``(row, element)`` of ``point``'s cell, clamped into the grid; fills
    ``lower`` (node index per axis) and ``weights`` (the multilinear weight of every
    corner, the products over axes 0, 1, ... in that order)."""
    row = 0
    col = 0
    weights[0] = 1.0
    count = 1
    for k in range(shape.size):
        i, t = _cell(point[k], lo[k], spacing[k], shape[k])
        lower[k] = i
        row += i * row_stride[k]
        col += i * col_stride[k]
        below = 1.0 - t
        for c in range(count):
            prefix = weights[c]
            weights[c] = prefix * below
            weights[c + count] = prefix * t
        count *= 2
    return row, col


@njit(cache=True)
def value_at(values, stored_of, row, col, corner_rows, corner_cols, weights):
    total = 0.0
    for corner in range(weights.size):
        weight = weights[corner]
        if weight != 0.0:
            total += weight * values[stored_of[row + corner_rows[corner]],
                                     col + corner_cols[corner]]
    return total


@njit(cache=True)
def _gradient_at(values, stored_of, row, col, shape, spacing, row_stride, col_stride,
                 corner_rows, corner_cols, lower, weights, axes, out):
    """The gradient's components along ``axes`` into ``out`` (one per axis)."""
    for a in range(axes.size):
        out[a] = 0.0
    for corner in range(weights.size):
        weight = weights[corner]
        if weight == 0.0:
            continue
        r = row + corner_rows[corner]
        c = col + corner_cols[corner]
        for a in range(axes.size):
            k = axes[a]
            node = lower[k] + ((corner >> k) & 1)
            up_r, up_c, down_r, down_c = r, c, r, c
            span = 0
            if node < shape[k] - 1:
                up_r += row_stride[k]
                up_c += col_stride[k]
                span += 1
            if node > 0:
                down_r -= row_stride[k]
                down_c -= col_stride[k]
                span += 1
            difference = values[stored_of[up_r], up_c] - values[stored_of[down_r], down_c]
            out[a] += weight * difference / (span * spacing[k])


_PARALLEL_FROM = 4096
"""Below this many query points the serial kernels are faster (no thread start-up)."""
_RUN = 1024
"""Points per task of the parallel kernels (a task sets up its strides and scratch once)."""


@njit(cache=True, inline="always")
def _interpolate_run(values, stored_of, shape, lo, spacing, points, start, stop, result):
    """``result[q]``: the value at ``points[q]`` for ``q`` in ``start..stop-1``. The loop of
    both interpolation kernels (the serial one's whole, a task of ``_RUN`` points of the
    parallel one's), inlined: a call costs as much as a point."""
    row_stride, col_stride = row_strides(shape, values.shape[1])
    corner_rows, corner_cols = corner_offsets(row_stride, col_stride)
    lower = np.empty(shape.size, dtype=np.int64)
    weights = np.empty(1 << shape.size, dtype=np.float64)
    for q in range(start, stop):
        row, col = locate_cell(points[q], shape, lo, spacing, row_stride, col_stride, lower,
                                weights)
        result[q] = value_at(values, stored_of, row, col, corner_rows, corner_cols, weights)


@njit(cache=True)
def _interpolate_serial(values, stored_of, shape, lo, spacing, points):
    result = np.empty(points.shape[0], dtype=np.float64)
    _interpolate_run(values, stored_of, shape, lo, spacing, points, 0, points.shape[0], result)
    return result


@njit(cache=True, parallel=True)
def _interpolate_parallel(values, stored_of, shape, lo, spacing, points):
    count = points.shape[0]
    result = np.empty(count, dtype=np.float64)
    chunks = (count + _RUN - 1) // _RUN
    for chunk in prange(chunks):
        _interpolate_run(values, stored_of, shape, lo, spacing, points, chunk * _RUN,
                         min((chunk + 1) * _RUN, count), result)
    return result


@njit(cache=True)
def gradient_point(values, stored_of, shape, lo, spacing, strides, corners, point, axes,
                    lower, weights, gradient, with_value):
    """Gradient along ``axes`` at one ``point`` into ``gradient``; returns the value there
    (``with_value``, else 0).
    ``strides`` and ``corners``: ``row_strides`` and ``corner_offsets`` of the grid."""
    row_stride, col_stride = strides
    row, col = locate_cell(point, shape, lo, spacing, row_stride, col_stride, lower, weights)
    _gradient_at(values, stored_of, row, col, shape, spacing, row_stride, col_stride,
                 corners[0], corners[1], lower, weights, axes, gradient)
    if not with_value:
        return 0.0
    return value_at(values, stored_of, row, col, corners[0], corners[1], weights)


@njit(cache=True, inline="always")
def _gradient_run(values, stored_of, shape, lo, spacing, points, axes, with_value, start, stop,
                  value, gradient):
    """``gradient[q]`` (and ``value[q]`` ``with_value``) at ``points[q]`` for ``q`` in
    ``start..stop-1``: the loop of both gradient kernels (as ``_interpolate_run``)."""
    strides = row_strides(shape, values.shape[1])
    corners = corner_offsets(strides[0], strides[1])
    lower = np.empty(shape.size, dtype=np.int64)
    weights = np.empty(1 << shape.size, dtype=np.float64)
    for q in range(start, stop):
        v = gradient_point(values, stored_of, shape, lo, spacing, strides, corners, points[q],
                           axes, lower, weights, gradient[q], with_value)
        if with_value:
            value[q] = v


@njit(cache=True)
def _gradient_serial(values, stored_of, shape, lo, spacing, points, axes, with_value):
    gradient = np.empty((points.shape[0], axes.size), dtype=np.float64)
    value = np.empty(points.shape[0] if with_value else 0, dtype=np.float64)
    _gradient_run(values, stored_of, shape, lo, spacing, points, axes, with_value, 0,
                  points.shape[0], value, gradient)
    return value, gradient


@njit(cache=True, parallel=True)
def _gradient_parallel(values, stored_of, shape, lo, spacing, points, axes, with_value):
    count = points.shape[0]
    gradient = np.empty((count, axes.size), dtype=np.float64)
    value = np.empty(count if with_value else 0, dtype=np.float64)
    chunks = (count + _RUN - 1) // _RUN
    for chunk in prange(chunks):
        _gradient_run(values, stored_of, shape, lo, spacing, points, axes, with_value,
                      chunk * _RUN, min((chunk + 1) * _RUN, count), value, gradient)
    return value, gradient


def interpolate(values: np.ndarray, stored_of: np.ndarray, shape: np.ndarray, lo: np.ndarray,
                spacing: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Multilinear interpolation at ``points (K, ndim)``, clamped into the grid (float64).

    ``values`` ``(stored rows, m)``: node ``flat`` (C order over ``shape``) is
    ``values[stored_of[flat // m], flat % m]`` (a whole array: ``values.reshape(1, -1)``
    with ``stored_of = [0]``)."""
    kernel = _interpolate_parallel if len(points) >= _PARALLEL_FROM else _interpolate_serial
    return kernel(values, stored_of, shape, lo, spacing, points)


def interpolate_gradient(values: np.ndarray, stored_of: np.ndarray, shape: np.ndarray,
                         lo: np.ndarray, spacing: np.ndarray, points: np.ndarray,
                         axes: np.ndarray) -> np.ndarray:
    """Nodal central differences (one-sided on the edges), interpolated multilinearly
    (``values`` and ``stored_of`` as in ``interpolate``): ``(K, len(axes))``, the
    components along the int64 ``axes``."""
    kernel = _gradient_parallel if len(points) >= _PARALLEL_FROM else _gradient_serial
    return kernel(values, stored_of, shape, lo, spacing, points, axes, False)[1]


def interpolate_with_gradient(values: np.ndarray, stored_of: np.ndarray, shape: np.ndarray,
                              lo: np.ndarray, spacing: np.ndarray, points: np.ndarray,
                              axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``interpolate`` and ``interpolate_gradient`` in one pass over each point's cell:
    ``(values (K,), gradients (K, len(axes)))``, equal to the two calls'."""
    kernel = _gradient_parallel if len(points) >= _PARALLEL_FROM else _gradient_serial
    return kernel(values, stored_of, shape, lo, spacing, points, axes, True)


# ---------------------------------------------------------------------------------------
# the records the generated iteration takes (``iteration.py``)
# ---------------------------------------------------------------------------------------

class RowLayout(NamedTuple):
    """The row layout (``layout.Layout``) as the iteration reads it: ``row_nodes``
    ``(stored rows, P)``, ``row_shape`` ``(P, 2)``, ``row_stride`` ``(P,)`` and
    ``stored_of`` ``(rows,)``, all int64; ``ny`` (int64): nodes along the last axis."""

    row_nodes: np.ndarray
    row_shape: np.ndarray
    row_stride: np.ndarray
    stored_of: np.ndarray
    ny: np.int64


class Motion(NamedTuple):
    """The players' motion as the schemes read it, one entry per player in the game's
    order: ``inv_h`` (float32, ``2 P + 2``): ``1 / spacing`` of each axis (per map unit);
    ``speeds`` (float32, map units per second); ``maximise`` (bool): a defender, which
    maximises the value."""

    inv_h: np.ndarray
    speeds: np.ndarray
    maximise: np.ndarray
