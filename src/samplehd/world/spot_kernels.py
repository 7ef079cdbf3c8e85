"""Compiled loops of the free-spot test (:mod:`samplehd.world.free_spot`): runs of columns, covered spots.

Each loop computes, element by element, the same IEEE operations as the array expression it stands
for (a product, a difference, a quotient, a minimum or maximum, a ceiling or floor, integer counts), so
its results equal that expression's bit for bit; sums of floats stay in numpy on the arrays returned.
The functions compile on their first call (a few seconds) and their machine code is cached on disk
beside this file, or where ``NUMBA_CACHE_DIR`` points (numba's rule; the cache holds code only, keyed
by this file's stamp and the argument types, so it can change how fast, never what comes out).

This module imports numba: :mod:`samplehd.world.free_spot` loads it when a spot is first tested, so
importing samplehd stays light.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["column_runs", "counts_outside", "farthest_picks", "near_objects", "uncovered"]


@numba.njit(cache=True, nogil=True)
def column_runs(q0: np.ndarray, along: np.ndarray, across: np.ndarray, lim: np.ndarray, u: np.ndarray,
                r0: int, r1: int, lo: float, width: float, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The first and last column of the run of a grid's spots each rectangle overlaps, per turn and row.

    On row ``i`` the separating-axis test along axis ``a`` of rectangle ``k``, turn ``t``, holds for a
    column coordinate ``v`` when ``|q0 - along * u[i] - across * v| <= lim``: a slab of ``v`` (all or
    none of it where ``across`` is 0). The run is the columns whose coordinate ``(j + 0.5) * width + lo``
    lies in all four slabs.

    Args:
        q0: (R, t, 4) each axis' projection of the centres' offset at the grid's origin [m].
        along: (R, t, 4) how the projection moves per metre along a row.
        across: (R, t, 4) ... and along a column.
        lim: (R, t, 4) how far apart along each axis the centres may be for an overlap [m].
        u: (r,) row coordinates [m].
        r0, r1: the rows ``r0``..``r1 - 1`` to compute; the others get no run.
        lo, width: the columns' start and width [m].
        count: the number of columns.

    Returns:
        first, last: (R, t, r) float columns, clipped to [0, count] and [-1, count - 1] (last < first:
        no run).
    """
    n_rect, n_turn, n_row = q0.shape[0], q0.shape[1], u.shape[0]
    first = np.full((n_rect, n_turn, n_row), float(count))
    last = np.full((n_rect, n_turn, n_row), -1.0)
    for k in range(n_rect):
        for t in range(n_turn):
            for i in range(r0, r1):
                low, high = -math.inf, math.inf
                for a in range(4):
                    q = q0[k, t, a] - along[k, t, a] * u[i]
                    c, m = across[k, t, a], lim[k, t, a]
                    if c == 0.0:  # an axis that ignores the column: all or none, by the row
                        if not abs(q) <= m:
                            low, high = math.inf, -math.inf
                    else:
                        x, y = (q - m) / c, (q + m) / c
                        low = max(low, min(x, y))
                        high = min(high, max(x, y))
                f = np.ceil((low - lo) / width - 0.5)
                g = np.floor((high - lo) / width - 0.5)
                first[k, t, i] = min(max(f, 0.0), float(count))
                last[k, t, i] = min(max(g, -1.0), float(count - 1))
    return first, last


@numba.njit(cache=True, nogil=True)
def uncovered(keep: np.ndarray, first: np.ndarray, last: np.ndarray, use: np.ndarray, count: int) -> np.ndarray:
    """The spots in ``keep`` that lie in none of the runs ``first``..``last`` of the rectangles in ``use``.

    Args:
        keep: (m,) spots in the order (turn, row, column), ``count`` columns a row.
        first, last: (R, t, r) each rectangle's run of columns per turn and row.
        use: (R,) which rectangles count.
        count: the number of columns.

    Returns:
        (m,) ``keep`` and outside every run.
    """
    size = keep.shape[0]
    n_turn, n_row = first.shape[1], first.shape[2]
    diff = np.zeros(size + 1, np.int64)
    for k in range(first.shape[0]):
        if not use[k]:
            continue
        for t in range(n_turn):
            for i in range(n_row):
                start, stop = int(first[k, t, i]), int(last[k, t, i]) + 1
                if start < stop:
                    row = (t * n_row + i) * count
                    diff[row + start] += 1
                    diff[row + stop] -= 1
    free = np.empty(size, np.bool_)
    running = 0
    for j in range(size):
        running += diff[j]
        free[j] = keep[j] and running <= 0
    return free


@numba.njit(cache=True, nogil=True)
def counts_outside(free: np.ndarray, first: np.ndarray, last: np.ndarray, count: int) -> np.ndarray:
    """How many spots in ``free`` of each turn lie outside each rectangle's runs ``first``..``last``.

    Args:
        free: (m,) spots in the order (turn, row, column), ``count`` columns a row.
        first, last: (R, t, r) each rectangle's run of columns per turn and row.
        count: the number of columns.

    Returns:
        (R, t) counts.
    """
    n_rect, n_turn, n_row = first.shape
    running = np.zeros(free.shape[0] + 1, np.int64)  # free spots before each spot
    for j in range(free.shape[0]):
        running[j + 1] = running[j] + free[j]
    out = np.empty((n_rect, n_turn), np.int64)
    for k in range(n_rect):
        for t in range(n_turn):
            row0 = t * n_row * count
            n = running[row0 + n_row * count] - running[row0]
            for i in range(n_row):
                start, stop = int(first[k, t, i]), int(last[k, t, i]) + 1
                if start < stop:
                    row = row0 + i * count
                    n -= running[row + stop] - running[row + start]
            out[k, t] = n
    return out


@numba.njit(cache=True, nogil=True)
def near_objects(keep: np.ndarray, n_turn: int, base: np.ndarray, axes: np.ndarray, u: np.ndarray, v: np.ndarray,
                 centre: np.ndarray, radius: np.ndarray, k: int) -> tuple[np.ndarray, int, int]:
    """The objects whose rectangle may block a spot of object k in ``keep``, and the rows holding such spots.

    The box around the footprint centres of every turn's spots in the first and last row and column
    holding a spot in ``keep`` is grown by both objects' reach (``radius``, with 1e-9 for rounding); an
    object whose centre lies outside it overlaps no such spot.

    Args:
        keep: (m,) spots in the order (turn, row, column).
        n_turn: the number of turns.
        base: (t, 2) origin of each turn's grid [m]; axes: (2, 2) the rows' and columns' directions.
        u, v: row and column coordinates [m].
        centre: (N, 2) footprint centres of the scene's objects [m]; radius: (N,) their reach [m].
        k: the object placed (never its own neighbour).

    Returns:
        The near objects in index order, and the rows ``r0``..``r1 - 1`` holding spots in ``keep``
        (0, 0: none, and no object is near).
    """
    n_row, n_col = u.shape[0], v.shape[0]
    row_any = np.zeros(n_row, np.bool_)
    col_any = np.zeros(n_col, np.bool_)
    for t in range(n_turn):
        for i in range(n_row):
            at = (t * n_row + i) * n_col
            for j in range(n_col):
                if keep[at + j]:
                    row_any[i] = True
                    col_any[j] = True
    rows, cols = np.flatnonzero(row_any), np.flatnonzero(col_any)
    if rows.shape[0] == 0:
        return np.zeros(0, np.int64), 0, 0
    lo = np.full(2, math.inf)
    hi = np.full(2, -math.inf)
    for t in range(base.shape[0]):
        for i in (rows[0], rows[-1]):
            for j in (cols[0], cols[-1]):
                for a in range(2):
                    corner = base[t, a] + u[i] * axes[0, a] + v[j] * axes[1, a]
                    lo[a] = min(lo[a], corner)
                    hi[a] = max(hi[a], corner)
    near = np.zeros(centre.shape[0], np.bool_)
    for n in range(centre.shape[0]):
        if n == k:
            continue
        grow = radius[k] + radius[n] + 1e-9
        near[n] = (abs(centre[n, 0] - (lo[0] + hi[0]) / 2) <= (hi[0] - lo[0]) / 2 + grow
                   and abs(centre[n, 1] - (lo[1] + hi[1]) / 2) <= (hi[1] - lo[1]) / 2 + grow)
    return np.flatnonzero(near), int(rows[0]), int(rows[-1]) + 1


@numba.njit(cache=True, nogil=True)
def farthest_picks(where: np.ndarray, most: int) -> np.ndarray:
    """Farthest-point picks among the rows of ``where`` (n, d): the first row, then each time the row
    farthest from every row picked (the first such), until ``most`` are picked or every row is picked's
    twin. Distances are ``sqrt`` of the squared differences summed left to right, as numpy sums a row."""
    n, dim = where.shape
    dist = np.empty(n)
    picks = np.empty(most, np.int64)
    picks[0] = 0
    count = 1
    for i in range(n):
        total = 0.0
        for a in range(dim):
            d = where[i, a] - where[0, a]
            total += d * d
        dist[i] = math.sqrt(total)
    while count < most:
        best, far = 0, dist[0]
        for i in range(1, n):
            if dist[i] > far:
                best, far = i, dist[i]
        if not far > 0:
            break
        picks[count] = best
        count += 1
        for i in range(n):
            total = 0.0
            for a in range(dim):
                d = where[i, a] - where[best, a]
                total += d * d
            dist[i] = min(dist[i], math.sqrt(total))
    return picks[:count]
