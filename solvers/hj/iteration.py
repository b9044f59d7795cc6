"""The game-independent half of every generated kernel module (``codegen``): one solver
iteration over listed rows, the row update it runs, and the projection onto the sets.

``codegen`` writes this file's text verbatim at the top of each generated module, so a
traceback's line numbers there are this file's, and appends the game's half, which
defines the four names used here without a definition (``noqa: F821``): ``WIDTH`` (the
scheme's stencil depth in nodes), ``in_row_piece`` and ``across_piece`` (the scheme's
pieces from ``kernels``) and ``apply_sets`` (the game's target and avoid update of one
row). This module is therefore never imported itself; ruff reads it, and the tests run it
through the generated modules against ``tests/kernels_reference.py``.

Every function takes plain arrays and the two records of ``kernels``: ``layout``
(``RowLayout``) and ``motion`` (``Motion``). Values are float32 rows ``(rows, m)``
(``layout.py``); ``dt`` is the time step (seconds, float32).
"""
import numpy as np
from numba import njit, prange

from solvers.hj.kernels import FASTMATH, in_row_differences, neighbour_rows

ZERO = np.float32(0.0)


@njit(cache=True, fastmath=FASTMATH)
def update_row(values, out, row_index, layout, motion, dt, tables, fx, fy, ham, jump, new, acc,
               nbr):
    """One row's update: the Hamiltonian of every player's piece, then the sets, into
    ``out[row_index]``; ``fx fy ham jump new acc nbr`` are the calling chunk's scratch."""
    players = layout.row_nodes.shape[1]
    inv_h, speeds, maximise = motion.inv_h, motion.speeds, motion.maximise
    row = values[row_index]
    in_row_differences(row, layout.ny, fx, fy)
    in_row_piece(row, layout.ny, fx, fy, inv_h[2 * players], inv_h[2 * players + 1],  # noqa: F821
                 speeds[players], maximise[players], ham, jump)
    neighbour_rows(row_index, layout.row_nodes, layout.row_shape, layout.row_stride,
                   layout.stored_of, WIDTH, nbr)  # noqa: F821
    for k in range(players):
        across_piece(row, values, nbr[k], inv_h[2 * k], inv_h[2 * k + 1],  # noqa: F821
                     speeds[k], maximise[k], ham, jump)
    apply_sets(row, new, ham, dt, jump, acc, layout.row_nodes[row_index], tables)  # noqa: F821
    target = out[row_index]
    for r in range(new.size):
        target[r] = new[r]


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def iterate(values, out, rows, planes, reverse, layout, motion, dt, tables, n_chunks):
    """One iteration: the rows ``rows[planes[p]:planes[p + 1]]`` of each plane ``p`` in
    parallel chunks, plane after plane (backwards with ``reverse``), from ``values`` into
    ``out`` (the same array for in-place red-black iterations).

    Returns the largest change of a value near the zero level set (value units).
    """
    m = values.shape[1]
    ny = layout.ny
    players = layout.row_nodes.shape[1]
    fx = np.empty((n_chunks, m + 3 * ny), dtype=np.float32)
    fy = np.empty((n_chunks, m + 3), dtype=np.float32)
    ham = np.empty((n_chunks, m), dtype=np.float32)
    jump = np.empty((n_chunks, m), dtype=np.float32)
    new = np.empty((n_chunks, m), dtype=np.float32)
    acc = np.zeros((n_chunks, m), dtype=np.float32)
    nbr = np.empty((n_chunks, players, 2, 2 * WIDTH), dtype=np.int64)  # noqa: F821
    n_planes = planes.size - 1
    for step in range(n_planes):
        plane = n_planes - 1 - step if reverse else step
        first = planes[plane]
        count = planes[plane + 1] - first
        chunks = min(count, n_chunks)
        for chunk in prange(chunks):
            for k in range(first + chunk * count // chunks, first + (chunk + 1) * count // chunks):
                update_row(values, out, rows[k], layout, motion, dt, tables, fx[chunk],
                           fy[chunk], ham[chunk], jump[chunk], new[chunk], acc[chunk],
                           nbr[chunk])
    best = ZERO
    for chunk in range(n_chunks):
        for r in range(m):
            best = max(best, acc[chunk, r])
    return best


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def project(values, rows, row_nodes, tables):
    """``values[row] = max(min(values[row], l), g)`` in place on the listed rows."""
    m = values.shape[1]
    for k in prange(rows.size):
        ham = np.zeros(m, dtype=np.float32)
        acc = np.zeros(m, dtype=np.float32)
        row = values[rows[k]]
        apply_sets(row, row, ham, ZERO, ham, acc, row_nodes[rows[k]], tables)  # noqa: F821
