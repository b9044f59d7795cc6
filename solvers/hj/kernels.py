"""Numba kernels of the reach-avoid solver and of grid interpolation.

Every kernel takes plain arrays; ``kernels_reference`` holds a slow numpy twin of each.

Layout of a game's value array (design.md section 4): the axes are the attackers' planar
positions first, then the defender's, ``(xA1, yA1[, xA2, yA2], xD, yD)``. The kernels see it
as a 2-D array ``(rows, m)``: one row per attacker configuration and the defender's two axes
flattened into ``m = nxD * nyD`` contiguous elements. Differences along the defender axes are
taken inside a row; differences along an attacker axis compare a row with a neighbouring
row. Each row is processed in short, branch-free passes over its ``m`` elements that LLVM
vectorises: one per player (the per-player pieces of the Hamiltonian) and one that applies
the game's target and avoid sets.

Scheme: ``V_new = max(min(V + dt * H, l), g)`` with the decoupled Hamiltonian
``H = -vA * sum_i |p_Ai| + vD * |p_D|`` (the attackers minimise, the defender maximises).
Spatial derivatives are one-sided differences ``D+`` and ``D-`` with a zero-gradient
boundary (a missing neighbour is replaced by the node itself). Godunov per player: the
defender's ``|p|`` is ``sqrt(sum_axes max(D+, -D-, 0)^2)`` and an attacker's
``sqrt(sum_axes max(-D+, D-, 0)^2)``; Lax-Friedrichs: ``|p|`` of the central difference
plus ``speed * (D+ - D-) / 2`` per axis. Both are monotone while
``dt <= 1 / sum_players (speed * sqrt(sum_axes h^-2))`` (Godunov) or
``dt <= 1 / sum_axes (speed / h)`` (Lax-Friedrichs).

Target and avoid functions are never stored as arrays of the value's size; they are
assembled per element from planar tables of the players' grids: ``target[a]`` (signed
distance to the target), ``attacker_free[a]`` and ``defender_free[d]`` (signed distance to
obstacles, negative inside), the node coordinates, and for 2 vs 1 the table
``survive[a, d]`` (the 1 vs 1 value: > 0 when that attacker loses its 1 vs 1 game). With
``gap = R - |a - d|`` (> 0: captured), ``reach = max(target[a], gap)`` (<= 0: in the target
uncaptured) and ``lost = max(gap, -attacker_free[a])`` (> 0: captured or in an obstacle):
1 vs 1: ``l = min(reach(a), defender_free)``, ``g = lost(a)``.
2 vs 1: ``l = min(reach(a1), reach(a2), defender_free)``,
``g = max(min(lost(a1), survive[a2]), min(lost(a2), survive[a1]))``.

A sweep updates rows plane after plane (``sweep``): all rows at once from a separate output
array (Jacobi), or in place with planes whose rows are never stencil neighbours of each other
(red-black Gauss-Seidel), so results never depend on the number of threads.

Convergence is measured on the nodes next to the zero level set: a node counts when its
absolute value is at most the largest jump to one of its stencil neighbours (so a
neighbour may have the other sign).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

_FASTMATH = {"nnan", "ninf", "nsz", "reassoc", "contract"}
_ZERO = np.float32(0.0)
_HALF = np.float32(0.5)
_HUGE = np.float32(1e30)
GODUNOV = 0
LAX_FRIEDRICHS = 1


# ---------------------------------------------------------------------------------------
# per-player pieces of one row
# ---------------------------------------------------------------------------------------

@njit(cache=True, fastmath=_FASTMATH)
def _row_differences(row, ny, fx, fy):
    """Raw forward differences of a row along the defender's two in-row axes.

    ``fx`` (length ``m + ny``) and ``fy`` (length ``m + 1``) are padded so that at element
    ``r`` the forward difference is ``fx[ny + r]`` / ``fy[1 + r]`` and the backward one
    ``fx[r]`` / ``fy[r]``; differences across the grid's edge are zero.
    """
    m = row.size
    for r in range(ny):
        fx[r] = _ZERO
        fx[m + r] = _ZERO
    ahead_x = row[ny:]
    out_x = fx[ny:]
    for r in range(m - ny):
        out_x[r] = ahead_x[r] - row[r]
    fy[0] = _ZERO
    fy[m] = _ZERO
    ahead_y = row[1:]
    out_y = fy[1:]
    for r in range(m - 1):
        out_y[r] = ahead_y[r] - row[r]
    for r in range(ny - 1, m, ny):
        out_y[r] = _ZERO


@njit(cache=True, fastmath=_FASTMATH)
def _defender_piece(fx, fy, ny, inv_hx, inv_hy, speed, scheme, ham, jump):
    """``ham = +speed * |p_D|`` (maximiser); ``jump`` starts as the in-row neighbour jumps."""
    m = ham.size
    fxp = fx[ny:]
    fyp = fy[1:]
    if scheme == GODUNOV:
        for r in range(m):
            qx = max(max(fxp[r], -fx[r]), _ZERO) * inv_hx
            qy = max(max(fyp[r], -fy[r]), _ZERO) * inv_hy
            ham[r] = speed * np.sqrt(qx * qx + qy * qy)
            jump[r] = max(max(abs(fxp[r]), abs(fx[r])), max(abs(fyp[r]), abs(fy[r])))
    else:
        for r in range(m):
            cx = (fxp[r] + fx[r]) * (_HALF * inv_hx)
            cy = (fyp[r] + fy[r]) * (_HALF * inv_hy)
            diss = (fxp[r] - fx[r]) * inv_hx + (fyp[r] - fy[r]) * inv_hy
            ham[r] = speed * (np.sqrt(cx * cx + cy * cy) + _HALF * diss)
            jump[r] = max(max(abs(fxp[r]), abs(fx[r])), max(abs(fyp[r]), abs(fy[r])))


@njit(cache=True, fastmath=_FASTMATH)
def _attacker_piece(row, xm, xp, ym, yp, inv_hx, inv_hy, speed, scheme, ham, jump):
    """``ham -= speed * |p_A|`` (minimiser) from the four neighbouring rows of one attacker.

    A neighbour row missing at the grid's edge is passed as ``row`` itself.
    """
    m = ham.size
    if scheme == GODUNOV:
        for r in range(m):
            v = row[r]
            ax = max(v - min(xp[r], xm[r]), _ZERO) * inv_hx
            ay = max(v - min(yp[r], ym[r]), _ZERO) * inv_hy
            ham[r] -= speed * np.sqrt(ax * ax + ay * ay)
            big = max(max(abs(xp[r] - v), abs(xm[r] - v)), max(abs(yp[r] - v), abs(ym[r] - v)))
            jump[r] = max(jump[r], big)
    else:
        for r in range(m):
            v = row[r]
            cx = (xp[r] - xm[r]) * (_HALF * inv_hx)
            cy = (yp[r] - ym[r]) * (_HALF * inv_hy)
            diss = (xp[r] + xm[r] - v - v) * inv_hx + (yp[r] + ym[r] - v - v) * inv_hy
            ham[r] += speed * (_HALF * diss - np.sqrt(cx * cx + cy * cy))
            big = max(max(abs(xp[r] - v), abs(xm[r] - v)), max(abs(yp[r] - v), abs(ym[r] - v)))
            jump[r] = max(jump[r], big)


@njit(cache=True, fastmath=_FASTMATH)
def _capture_gap(r, ax, ay, dxs, dys, radius):
    """``R - |a - d|`` for attacker node ``(ax, ay)`` and defender node ``r``."""
    ex = ax - dxs[r]
    ey = ay - dys[r]
    return radius - np.sqrt(ex * ex + ey * ey)


@njit(cache=True, fastmath=_FASTMATH)
def _close_1v1(row, new, ham, jump, dt, a, sets, acc):
    """Apply the 1 vs 1 sets to a row."""
    target, attacker_free, ax, ay, dxs, dys, defender_free, radius = sets
    t, f, x, y = target[a], attacker_free[a], ax[a], ay[a]
    for r in range(row.size):
        v = row[r]
        gap = _capture_gap(r, x, y, dxs, dys, radius)
        reach = min(max(t, gap), defender_free[r])
        lost = max(gap, -f)
        updated = max(min(v + dt * ham[r], reach), lost)
        new[r] = updated
        step = abs(updated - v)
        acc[r] = max(acc[r], step if abs(v) <= jump[r] else _ZERO)


@njit(cache=True, fastmath=_FASTMATH)
def _close_2v1(row, new, ham, jump, dt, a1, a2, sets, survive, acc):
    """Apply the 2 vs 1 sets to a row."""
    target, attacker_free, ax, ay, dxs, dys, defender_free, radius = sets
    t1, f1, x1, y1 = target[a1], attacker_free[a1], ax[a1], ay[a1]
    t2, f2, x2, y2 = target[a2], attacker_free[a2], ax[a2], ay[a2]
    survive1, survive2 = survive[a1], survive[a2]
    for r in range(row.size):
        v = row[r]
        gap1 = _capture_gap(r, x1, y1, dxs, dys, radius)
        gap2 = _capture_gap(r, x2, y2, dxs, dys, radius)
        reach = min(min(max(t1, gap1), max(t2, gap2)), defender_free[r])
        avoid = max(min(max(gap1, -f1), survive2[r]), min(max(gap2, -f2), survive1[r]))
        updated = max(min(v + dt * ham[r], reach), avoid)
        new[r] = updated
        step = abs(updated - v)
        acc[r] = max(acc[r], step if abs(v) <= jump[r] else _ZERO)


# ---------------------------------------------------------------------------------------
# row bookkeeping shared by both games
# ---------------------------------------------------------------------------------------

@njit(cache=True)
def _attacker_index(row, player, n_attackers, na):
    """Flat grid index of attacker ``player`` in ``row`` (rows are ``(a1[, a2])`` in C order)."""
    stride = 1 if player == n_attackers - 1 else na
    return (row // stride) % na


@njit(cache=True)
def canonical_row(row, n_attackers, na, symmetric):
    """The row that stores ``row``: with exchange symmetry, ``(a1, a2)`` and ``(a2, a1)`` are
    both stored at the one with ``a1 >= a2``."""
    if symmetric and n_attackers == 2:
        a1 = row // na
        a2 = row % na
        if a1 < a2:
            return a2 * na + a1
    return row


@njit(cache=True)
def _neighbour_rows(row, n_attackers, na, any_, anx, symmetric, out):
    """``out[player] = (x-, x+, y-, y+)`` neighbour rows, the row itself on the grid's edge."""
    for player in range(n_attackers):
        stride = 1 if player == n_attackers - 1 else na
        a = (row // stride) % na
        ix = a // any_
        iy = a % any_
        out[player, 0] = canonical_row(row - any_ * stride if ix > 0 else row,
                                       n_attackers, na, symmetric)
        out[player, 1] = canonical_row(row + any_ * stride if ix < anx - 1 else row,
                                       n_attackers, na, symmetric)
        out[player, 2] = canonical_row(row - stride if iy > 0 else row,
                                       n_attackers, na, symmetric)
        out[player, 3] = canonical_row(row + stride if iy < any_ - 1 else row,
                                       n_attackers, na, symmetric)


@njit(cache=True, fastmath=_FASTMATH)
def _update_row(values, out, row_index, n_attackers, any_, anx, dny, inv_h, speeds, dt, scheme,
                symmetric, sets, survive, fx, fy, ham, jump, new, acc, nbr):
    """Update one row: every read of ``values`` happens before ``out[row_index]`` is written,
    so ``out`` may be ``values`` itself (Gauss-Seidel)."""
    na = anx * any_
    row = values[row_index]
    _row_differences(row, dny, fx, fy)
    _defender_piece(fx, fy, dny, inv_h[2 * n_attackers], inv_h[2 * n_attackers + 1], speeds[1],
                    scheme, ham, jump)
    _neighbour_rows(row_index, n_attackers, na, any_, anx, symmetric, nbr)
    for player in range(n_attackers):
        _attacker_piece(row, values[nbr[player, 0]], values[nbr[player, 1]],
                        values[nbr[player, 2]], values[nbr[player, 3]], inv_h[2 * player],
                        inv_h[2 * player + 1], speeds[0], scheme, ham, jump)
    a1 = _attacker_index(row_index, 0, n_attackers, na)
    if n_attackers == 1:
        _close_1v1(row, new, ham, jump, dt, a1, sets, acc)
    else:
        a2 = _attacker_index(row_index, 1, n_attackers, na)
        _close_2v1(row, new, ham, jump, dt, a1, a2, sets, survive, acc)
    target = out[row_index]
    for r in range(new.size):
        target[r] = new[r]


@njit(cache=True, parallel=True, fastmath=_FASTMATH)
def sweep(values, out, rows, planes, reverse, n_attackers, any_, anx, dny, inv_h, speeds, dt,
          scheme, symmetric, sets, survive, n_chunks):
    """One step of the reach-avoid update over ``rows``, plane after plane.

    - ``values``, ``out``: ``(R, m)`` float32. Distinct arrays: a Jacobi step (one plane).
      The same array: Gauss-Seidel, updated in place; the rows of one plane must not be
      stencil neighbours of each other (then the result does not depend on threading).
    - ``rows``: int64 rows to update, grouped by plane: plane ``p`` is
      ``rows[planes[p]:planes[p + 1]]``; planes run in order, or backwards with ``reverse``.
      Rows not listed are left untouched in ``out``.
    - ``any_``, ``anx``: attacker grid nodes along y and x (``na = anx * any_``);
      ``dny``: defender nodes along y (``m = dnx * dny``).
    - ``inv_h``: float32 ``(2 * n_attackers + 2,)`` inverse spacings in axis order.
    - ``speeds``: float32 ``(attacker, defender)``; ``dt``: float32 time step.
    - ``sets``: the planar tables ``(target (na,), attacker_free (na,), ax (na,), ay (na,),
      dx (m,), dy (m,), defender_free (m,), capture_radius)``, float32 (node coordinates
      ``ax``, ``ay`` of the attacker grid and ``dx``, ``dy`` of the defender grid, flat).
    - ``survive``: ``(na, m)`` 1 vs 1 value table (2 vs 1 only; any 2-D array otherwise).
    - ``n_chunks``: the rows of a plane are split into this many chunks for the threads.

    Returns the largest change near the zero level set (divide by ``dt`` for the change per
    unit game time).
    """
    m = values.shape[1]
    fx = np.empty((n_chunks, m + dny), dtype=np.float32)
    fy = np.empty((n_chunks, m + 1), dtype=np.float32)
    ham = np.empty((n_chunks, m), dtype=np.float32)
    jump = np.empty((n_chunks, m), dtype=np.float32)
    new = np.empty((n_chunks, m), dtype=np.float32)
    acc = np.zeros((n_chunks, m), dtype=np.float32)
    nbr = np.empty((n_chunks, n_attackers, 4), dtype=np.int64)
    n_planes = planes.size - 1
    for step in range(n_planes):
        plane = n_planes - 1 - step if reverse else step
        first = planes[plane]
        count = planes[plane + 1] - first
        chunks = min(count, n_chunks)
        for chunk in prange(chunks):
            for k in range(first + chunk * count // chunks, first + (chunk + 1) * count // chunks):
                _update_row(values, out, rows[k], n_attackers, any_, anx, dny, inv_h, speeds, dt,
                            scheme, symmetric, sets, survive, fx[chunk], fy[chunk], ham[chunk],
                            jump[chunk], new[chunk], acc[chunk], nbr[chunk])
    best = _ZERO
    for chunk in range(n_chunks):
        for r in range(m):
            best = max(best, acc[chunk, r])
    return best


@njit(cache=True, parallel=True, fastmath=_FASTMATH)
def initial_values(out, rows, n_attackers, na, sets, survive):
    """``out[row] = max(l, g)`` on the given rows: the value at zero time-to-go."""
    m = out.shape[1]
    ham = np.zeros(m, dtype=np.float32)
    huge = np.full(m, _HUGE, dtype=np.float32)
    for k in prange(rows.size):
        row_index = rows[k]
        acc = np.zeros(m, dtype=np.float32)
        jump = np.zeros(m, dtype=np.float32)
        a1 = _attacker_index(row_index, 0, n_attackers, na)
        if n_attackers == 1:
            _close_1v1(huge, out[row_index], ham, jump, _ZERO, a1, sets, acc)
        else:
            a2 = _attacker_index(row_index, 1, n_attackers, na)
            _close_2v1(huge, out[row_index], ham, jump, _ZERO, a1, a2, sets, survive, acc)


@njit(cache=True, parallel=True)
def mirror_rows(values, na):
    """Fill the rows ``(a1, a2)`` with ``a1 < a2`` from their stored twins ``(a2, a1)``."""
    m = values.shape[1]
    for a1 in prange(na):
        for a2 in range(a1 + 1, na):
            source = values[a2 * na + a1]
            target = values[a1 * na + a2]
            for r in range(m):
                target[r] = source[r]


# ---------------------------------------------------------------------------------------
# interpolation
# ---------------------------------------------------------------------------------------

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
def _strides(shape):
    ndim = shape.size
    strides = np.empty(ndim, dtype=np.int64)
    s = 1
    for k in range(ndim - 1, -1, -1):
        strides[k] = s
        s *= shape[k]
    return strides


@njit(cache=True)
def _locate(point, shape, lo, spacing, strides, frac, lower):
    """Flat index of the cell's lowest corner; fills ``frac`` and ``lower`` per axis."""
    base = 0
    for k in range(shape.size):
        i, t = _cell(point[k], lo[k], spacing[k], shape[k])
        base += i * strides[k]
        frac[k] = t
        lower[k] = i
    return base


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
def _value_at(values, point, shape, lo, spacing, strides, frac, lower):
    base = _locate(point, shape, lo, spacing, strides, frac, lower)
    total = 0.0
    for corner in range(1 << shape.size):
        weight, offset = _corner(corner, base, frac, strides)
        if weight != 0.0:
            total += weight * values[offset]
    return total


@njit(cache=True)
def _gradient_at(values, point, shape, lo, spacing, strides, frac, lower, out):
    base = _locate(point, shape, lo, spacing, strides, frac, lower)
    for k in range(shape.size):
        out[k] = 0.0
    for corner in range(1 << shape.size):
        weight, offset = _corner(corner, base, frac, strides)
        if weight == 0.0:
            continue
        for k in range(shape.size):
            node = lower[k] + ((corner >> k) & 1)
            up = offset + strides[k] if node < shape[k] - 1 else offset
            down = offset - strides[k] if node > 0 else offset
            span = (up - down) // strides[k]
            out[k] += weight * (values[up] - values[down]) / (span * spacing[k])


_PARALLEL_FROM = 4096
"""Below this many query points the serial kernels are faster (no thread start-up)."""


@njit(cache=True)
def _interpolate_serial(values, shape, lo, spacing, points):
    strides = _strides(shape)
    frac = np.empty(shape.size, dtype=np.float64)
    lower = np.empty(shape.size, dtype=np.int64)
    result = np.empty(points.shape[0], dtype=np.float64)
    for q in range(points.shape[0]):
        result[q] = _value_at(values, points[q], shape, lo, spacing, strides, frac, lower)
    return result


@njit(cache=True, parallel=True)
def _interpolate_parallel(values, shape, lo, spacing, points):
    strides = _strides(shape)
    result = np.empty(points.shape[0], dtype=np.float64)
    for q in prange(points.shape[0]):
        frac = np.empty(shape.size, dtype=np.float64)
        lower = np.empty(shape.size, dtype=np.int64)
        result[q] = _value_at(values, points[q], shape, lo, spacing, strides, frac, lower)
    return result


@njit(cache=True)
def _gradient_serial(values, shape, lo, spacing, points):
    strides = _strides(shape)
    frac = np.empty(shape.size, dtype=np.float64)
    lower = np.empty(shape.size, dtype=np.int64)
    result = np.empty((points.shape[0], shape.size), dtype=np.float64)
    for q in range(points.shape[0]):
        _gradient_at(values, points[q], shape, lo, spacing, strides, frac, lower, result[q])
    return result


@njit(cache=True, parallel=True)
def _gradient_parallel(values, shape, lo, spacing, points):
    strides = _strides(shape)
    result = np.empty((points.shape[0], shape.size), dtype=np.float64)
    for q in prange(points.shape[0]):
        frac = np.empty(shape.size, dtype=np.float64)
        lower = np.empty(shape.size, dtype=np.int64)
        _gradient_at(values, points[q], shape, lo, spacing, strides, frac, lower, result[q])
    return result


def interpolate(values: np.ndarray, shape: np.ndarray, lo: np.ndarray, spacing: np.ndarray,
                points: np.ndarray) -> np.ndarray:
    """Multilinear interpolation of flat C-order ``values`` at ``points (K, ndim)``, clamped
    into the grid (float64)."""
    kernel = _interpolate_parallel if len(points) >= _PARALLEL_FROM else _interpolate_serial
    return kernel(values, shape, lo, spacing, points)


def interpolate_gradient(values: np.ndarray, shape: np.ndarray, lo: np.ndarray,
                         spacing: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Nodal central differences (one-sided on the edges), interpolated multilinearly."""
    kernel = _gradient_parallel if len(points) >= _PARALLEL_FROM else _gradient_serial
    return kernel(values, shape, lo, spacing, points)
