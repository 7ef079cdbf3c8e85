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

__all__ = ["annulus_and", "best_spots", "column_runs", "counts_outside", "farthest_picks", "near_objects", "part_keep",
           "uncovered"]


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


@numba.njit(cache=True, nogil=True)
def annulus_and(keep: np.ndarray, rel_x: np.ndarray, rel_y: np.ndarray, sq_lo: float, sq_hi: float, sure_lo: float,
                sure_hi: float, gap_lo: float, gap_hi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Keep (in place) only the spots whose squared distance ``rel_x**2 + rel_y**2`` lies surely inside
    [``sure_lo``, ``sure_hi``], and list the kept ones it leaves unsure (within ``gap_lo`` of ``sq_lo`` or
    ``gap_hi`` of ``sq_hi``) for the caller to decide on the distance itself.

    Args:
        keep: (t, r, c) spots; rel_x, rel_y: offsets from the centre of the annulus, each of a shape that
            broadcasts to keep's (its axes of length 1 repeat) [m].

    Returns:
        The flat indices of the unsure spots (left kept) and their ``rel_x``, ``rel_y``.
    """
    n_turn, n_row, n_col = keep.shape
    unsure = np.empty(keep.size, np.int64)
    found = 0
    for t in range(n_turn):
        tx, ty = min(t, rel_x.shape[0] - 1), min(t, rel_y.shape[0] - 1)
        for i in range(n_row):
            ix, iy = min(i, rel_x.shape[1] - 1), min(i, rel_y.shape[1] - 1)
            for j in range(n_col):
                if not keep[t, i, j]:
                    continue
                x, y = rel_x[tx, ix, min(j, rel_x.shape[2] - 1)], rel_y[ty, iy, min(j, rel_y.shape[2] - 1)]
                sq = x * x + y * y
                if abs(sq - sq_lo) < gap_lo or abs(sq - sq_hi) < gap_hi:
                    unsure[found] = (t * n_row + i) * n_col + j
                    found += 1
                elif not (sq >= sure_lo and sq <= sure_hi):
                    keep[t, i, j] = False
    xs, ys = np.empty(found), np.empty(found)
    for n in range(found):
        t, rest = divmod(unsure[n], n_row * n_col)
        i, j = divmod(rest, n_col)
        xs[n] = rel_x[min(t, rel_x.shape[0] - 1), min(i, rel_x.shape[1] - 1), min(j, rel_x.shape[2] - 1)]
        ys[n] = rel_y[min(t, rel_y.shape[0] - 1), min(i, rel_y.shape[1] - 1), min(j, rel_y.shape[2] - 1)]
    return unsure[:found], xs, ys


@numba.njit(cache=True, nogil=True)
def part_keep(u: np.ndarray, v: np.ndarray, offsets: np.ndarray, half: np.ndarray, lo: np.ndarray, hi: np.ndarray,
              table: np.ndarray, base: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tests of a table part's spots that need no other object and no distance: the frame origin
    inside the part's bounds and the footprint inside the table's, each on x (rows) or y (columns) alone.

    Args:
        u, v: the rows' x and the columns' y of the footprint centres [m].
        offsets: (t, 2) footprint centre minus frame origin per turn; half: (t, 2) the turned footprint's
            world-axis half sizes [m].
        lo, hi: (2,) the part's bounds for the origin; table: (2,) the table's half sizes less its edge;
        base: (2,) the robot base [m].

    Returns:
        keep (t, r, c), and the origins' offsets from the base: x (t, r, 1) and y (t, 1, c) [m].
    """
    n_turn = offsets.shape[0]
    rel_x = np.empty((n_turn, u.shape[0], 1))
    rel_y = np.empty((n_turn, 1, v.shape[0]))
    row_ok = np.empty((n_turn, u.shape[0]), np.bool_)
    col_ok = np.empty((n_turn, v.shape[0]), np.bool_)
    for t in range(n_turn):
        for a, coords, ok in ((0, u, row_ok), (1, v, col_ok)):
            for i in range(coords.shape[0]):
                o = coords[i] - offsets[t, a]
                ok[t, i] = ((o >= lo[a]) and (o <= hi[a]) and (coords[i] - half[t, a] >= -table[a])
                            and (coords[i] + half[t, a] <= table[a]))
                if a == 0:
                    rel_x[t, i, 0] = o - base[0]
                else:
                    rel_y[t, 0, i] = o - base[1]
    keep = np.empty((n_turn, u.shape[0], v.shape[0]), np.bool_)
    for t in range(n_turn):
        for i in range(u.shape[0]):
            for j in range(v.shape[0]):
                keep[t, i, j] = row_ok[t, i] and col_ok[t, j]
    return keep, rel_x, rel_y


@numba.njit(cache=True, nogil=True)
def best_spots(free: np.ndarray, on_axes: bool, u: np.ndarray, v: np.ndarray, centre: np.ndarray,
               neighbours: np.ndarray, score: np.ndarray, shares: np.ndarray, room_cap: float,
               needed: int, shortlist: float) -> tuple[np.ndarray, np.ndarray]:
    """The free spots ranked best first by the planner's score, and how many of them hold the shortlist.

    A spot's score is its ``score`` less its distance to the nearest neighbour centre capped at
    ``room_cap``; the ranking is the start of the stable order of the scores, at least ``needed`` long
    (every score up to the ``needed``-th smallest, ties included). The best are the first spots whose
    running sum of ``shares`` (summed left to right, as numpy's cumulative sum) stays within
    ``shortlist``, at least one.

    Args:
        free: (m,) the free spots.
        on_axes: the grid's rows and columns are x and y: spot ``s`` is centred at ``(u[i], v[j])`` with
            ``i, j`` its row and column (``centre`` is then not read).
        u, v: the grid's row and column coordinates [m]; centre: (m, 2) the spots' centres [m].
        neighbours: (N, 2) the other objects' footprint centres [m].
        score: (m,) the planner's score terms that do not depend on the neighbours.
        shares: (m,) the planner's samples expected on each spot.

    Returns:
        ranked (the spots, best first) and how many of them are the best.
    """
    idx = np.flatnonzero(free)
    n_row, n_col = u.shape[0], v.shape[0]
    key = np.empty(idx.shape[0])
    for m in range(idx.shape[0]):
        s = idx[m]
        gap = math.inf
        if on_axes:
            i, j = divmod(s % (n_row * n_col), n_col)
            for n in range(neighbours.shape[0]):
                dx, dy = u[i] - neighbours[n, 0], v[j] - neighbours[n, 1]
                gap = min(gap, dx * dx + dy * dy)
            gap = math.sqrt(gap)  # the square root is monotone: the root of the least square is the least root
        else:
            for n in range(neighbours.shape[0]):
                dx, dy = centre[s, 0] - neighbours[n, 0], centre[s, 1] - neighbours[n, 1]
                gap = min(gap, math.sqrt(dx * dx + dy * dy))
        key[m] = -min(gap, room_cap) + score[s]
    if needed >= key.shape[0]:
        order = np.argsort(key, kind="mergesort")
    else:
        bound = np.partition(key, needed - 1)[needed - 1]
        sel = np.flatnonzero(key <= bound)
        order = sel[np.argsort(key[sel], kind="mergesort")]
    ranked = idx[order]
    total, count = 0.0, 0
    for m in range(ranked.shape[0]):
        total += shares[ranked[m]]
        if total > shortlist:
            break
        count += 1
    return ranked, max(1, count)
