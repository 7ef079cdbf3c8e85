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

__all__ = ["beside_keep", "best_spots", "blocked_weight", "blockers", "clear_points", "clearance", "column_runs",
           "counts_outside", "farthest_picks", "free_spots", "in_annulus", "near_objects", "option_counts",
           "part_keep", "rect_runs", "spot_options", "spot_scores", "uncovered", "uncovered_weight", "weight_sum"]


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
            _row_runs(q0[k, t], along[k, t], across[k, t], lim[k, t], u, r0, r1, lo, width, count, first[k, t],
                      last[k, t])
    return first, last


@numba.njit(cache=True, nogil=True)
def _row_runs(q0: np.ndarray, along: np.ndarray, across: np.ndarray, lim: np.ndarray, u: np.ndarray, r0: int,
              r1: int, lo: float, width: float, count: int, first: np.ndarray, last: np.ndarray) -> None:
    """:func:`column_runs` of one rectangle and turn (its four axes (4,)), into ``first``, ``last`` (r,).

    The slabs' bounds are first taken with the reciprocals of ``across`` and ``width`` (a few units in the
    last place from the quotients); a row whose first or last column so found lies within 1e-9 of a whole
    column, far above that difference, is taken again with the quotients themselves
    (:func:`_row_run_exact`), so every run is the quotients' own."""
    inv = np.empty(4)
    for a in range(4):
        inv[a] = 1.0 / across[a] if across[a] != 0.0 else 0.0
        if not math.isfinite(inv[a]):  # (an axis all but along the rows: the quotients throughout)
            for i in range(r0, r1):
                first[i], last[i] = _row_run_exact(q0, along, across, lim, u[i], lo, width, count)
            return
    inv_width = 1.0 / width
    for i in range(r0, r1):
        low, high = -math.inf, math.inf
        for a in range(4):
            q = q0[a] - along[a] * u[i]
            c, m = across[a], lim[a]
            if c == 0.0:  # an axis that ignores the column: all or none, by the row
                if not abs(q) <= m:
                    low, high = math.inf, -math.inf
            else:
                x, y = (q - m) * inv[a], (q + m) * inv[a]
                low = max(low, min(x, y))
                high = min(high, max(x, y))
        s, e = (low - lo) * inv_width - 0.5, (high - lo) * inv_width - 0.5
        if _near_whole(s) or _near_whole(e):
            first[i], last[i] = _row_run_exact(q0, along, across, lim, u[i], lo, width, count)
        else:
            first[i] = min(max(np.ceil(s), 0.0), float(count))
            last[i] = min(max(np.floor(e), -1.0), float(count - 1))


@numba.njit(cache=True, nogil=True, inline="always")
def _near_whole(t: float) -> bool:
    """Whether a finite column coordinate lies within 1e-9 (relative to its size) of a whole column."""
    return math.isfinite(t) and not abs(t - np.rint(t)) > 1e-9 * (1.0 + abs(t))


@numba.njit(cache=True, nogil=True)
def _row_run_exact(q0: np.ndarray, along: np.ndarray, across: np.ndarray, lim: np.ndarray, u: float, lo: float,
                   width: float, count: int) -> tuple[float, float]:
    """The first and last column of one row's run (:func:`column_runs`), with the quotients themselves."""
    low, high = -math.inf, math.inf
    for a in range(4):
        q = q0[a] - along[a] * u
        c, m = across[a], lim[a]
        if c == 0.0:  # an axis that ignores the column: all or none, by the row
            if not abs(q) <= m:
                low, high = math.inf, -math.inf
        else:
            x, y = (q - m) / c, (q + m) / c
            low = max(low, min(x, y))
            high = min(high, max(x, y))
    f = np.ceil((low - lo) / width - 0.5)
    g = np.floor((high - lo) / width - 0.5)
    return min(max(f, 0.0), float(count)), min(max(g, -1.0), float(count - 1))


@numba.njit(cache=True, nogil=True)
def rect_runs(rt: np.ndarray, half: np.ndarray, rots: np.ndarray, halves: np.ndarray, centres: np.ndarray,
              index: np.ndarray, grow: float, base: np.ndarray, grid_axes: np.ndarray, u: np.ndarray, r0: int,
              r1: int, lo: float, width: float, count: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`column_runs` of an object turned by each of ``rt`` against rectangles, from their poses.

    The test's axes, the reach along each and the projections are the products of 2-vectors that
    :mod:`samplehd.world.free_spot` takes with :func:`samplehd.fixedmath.matmul`, here with the same
    rounding: every product of 2-vectors is ``a0 * b0 + a1 * b1``, each product and the sum rounded on
    their own (no fused multiply-add); tests check the bits against those array expressions.

    Args:
        rt: (t, 2, 2) the placed object's rotation after each turn; half: (2,) its half sizes [m].
        rots, halves, centres: (N, 2, 2), (N, 2), (N, 2) the rectangles' rotations, half sizes and
            footprint centres [m]; index: (R,) which of them to test.
        grow: half the spot margin, added to every half size [m].
        base: (t, 2) the grid's origin per turn; grid_axes: (2, 2) its rows' and columns' directions.
        u, r0, r1, lo, width, count: as :func:`column_runs`.

    Returns:
        first, last: (R, t, r), as :func:`column_runs`.
    """
    return _rect_runs(rt, half, rots, halves, centres, index, grow, base, grid_axes, u, r0, r1, lo, width, count,
                      np.zeros(0))


@numba.njit(cache=True, nogil=True)
def _rect_runs(rt: np.ndarray, half: np.ndarray, rots: np.ndarray, halves: np.ndarray, centres: np.ndarray,
               index: np.ndarray, grow: float, base: np.ndarray, grid_axes: np.ndarray, u: np.ndarray, r0: int,
               r1: int, lo: float, width: float, count: int, reach: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`rect_runs`; where ``reach`` (N,) is given, only on the rows whose coordinate ``u`` (ascending)
    lies within ``reach[n]`` of rectangle n's centre along the rows (its offset from each turn's grid origin
    along the rows' direction): a spot farther than the sum of both rectangles' half diagonals can overlap
    neither, so the other rows' runs are empty and are left as none (first = count, last = -1)."""
    n_rect, n_turn, n_row = index.shape[0], rt.shape[0], u.shape[0]
    first = np.full((n_rect, n_turn, n_row), float(count))
    last = np.full((n_rect, n_turn, n_row), -1.0)
    axes = np.empty((4, 2))
    q0, along, across, lim = np.empty(4), np.empty(4), np.empty(4), np.empty(4)
    hk0, hk1 = half[0] + grow, half[1] + grow
    for m in range(n_rect):
        n = index[m]
        h0, h1 = halves[n, 0] + grow, halves[n, 1] + grow
        for t in range(n_turn):
            for a in range(2):  # the rows: the turned object's axes, then the rectangle's
                axes[a, 0], axes[a, 1] = rt[t, 0, a], rt[t, 1, a]
                axes[2 + a, 0], axes[2 + a, 1] = rots[n, 0, a], rots[n, 1, a]
            dx, dy = centres[n, 0] - base[t, 0], centres[n, 1] - base[t, 1]
            for a in range(4):
                x, y = axes[a, 0], axes[a, 1]
                own = abs(x * rt[t, 0, 0] + y * rt[t, 1, 0]) * hk0 + abs(x * rt[t, 0, 1] + y * rt[t, 1, 1]) * hk1
                other = (abs(x * rots[n, 0, 0] + y * rots[n, 1, 0]) * h0
                         + abs(x * rots[n, 0, 1] + y * rots[n, 1, 1]) * h1)
                lim[a] = own + other
                q0[a] = x * dx + y * dy
                along[a] = x * grid_axes[0, 0] + y * grid_axes[0, 1]
                across[a] = x * grid_axes[1, 0] + y * grid_axes[1, 1]
            a0, a1 = r0, r1
            if reach.shape[0]:
                at = dx * grid_axes[0, 0] + dy * grid_axes[0, 1]
                a0 = max(a0, np.searchsorted(u, at - reach[n]))
                a1 = min(a1, np.searchsorted(u, at + reach[n], side="right"))
            _row_runs(q0, along, across, lim, u, a0, a1, lo, width, count, first[m, t], last[m, t])
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
    diff = np.zeros(keep.shape[0] + 1, np.int64)
    _mark_runs(diff, first, last, use, count)
    return _outside_marks(keep, diff)


@numba.njit(cache=True, nogil=True)
def _mark_runs(diff: np.ndarray, first: np.ndarray, last: np.ndarray, use: np.ndarray, count: int) -> None:
    """Add each run of the rectangles in ``use`` to ``diff`` (m + 1,): +1 at its first spot, -1 past its last."""
    n_turn, n_row = first.shape[1], first.shape[2]
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


@numba.njit(cache=True, nogil=True)
def _outside_marks(keep: np.ndarray, diff: np.ndarray) -> np.ndarray:
    """The spots in ``keep`` that no marked run (:func:`_mark_runs`) covers."""
    free = np.empty(keep.shape[0], np.bool_)
    running = 0
    for j in range(keep.shape[0]):
        running += diff[j]
        free[j] = keep[j] and running <= 0
    return free


@numba.njit(cache=True, nogil=True)
def free_spots(keep: np.ndarray, first: np.ndarray, last: np.ndarray, use: np.ndarray, rt: np.ndarray,
               half: np.ndarray, rots: np.ndarray, halves: np.ndarray, centres: np.ndarray, grow: float,
               base: np.ndarray, grid_axes: np.ndarray, u: np.ndarray, lo: float, width: float,
               count: int) -> np.ndarray:
    """An object's free spots in one call: the spots in ``keep`` outside the runs of the scene's objects in
    ``use`` (``first``, ``last``, as :func:`uncovered`) and outside every placed rectangle (``rots``,
    ``halves``, ``centres``, their runs on every row by :func:`rect_runs` with the other arguments).

    Returns:
        (m,) ``uncovered(uncovered(keep, first, last, use), *rect_runs(...), all)``, in one pass.
    """
    diff = np.zeros(keep.shape[0] + 1, np.int64)
    _mark_runs(diff, first, last, use, count)
    n_placed = centres.shape[0]
    if n_placed:
        pf, pl = rect_runs(rt, half, rots, halves, centres, np.arange(n_placed), grow, base, grid_axes, u, 0,
                           u.shape[0], lo, width, count)
        _mark_runs(diff, pf, pl, np.ones(n_placed, np.bool_), count)
    return _outside_marks(keep, diff)


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
               neighbours: np.ndarray, score: np.ndarray, rel_x: np.ndarray, rel_y: np.ndarray, turns: np.ndarray,
               turn: np.ndarray, weights: np.ndarray, shares: np.ndarray, room_cap: float,
               needed: int, shortlist: float) -> tuple[np.ndarray, np.ndarray]:
    """The free spots ranked best first by the planner's score, and how many of them hold the shortlist.

    A spot's score is its terms that do not depend on the neighbours (:func:`spot_scores`) less its
    distance to the nearest neighbour centre capped at ``room_cap``; the ranking is the start of the stable
    order of the scores, at least ``needed`` long (every score up to the ``needed``-th smallest, ties
    included). The best are the first spots whose running sum of ``shares`` (summed left to right, as
    numpy's cumulative sum) stays within ``shortlist``, at least one.

    The scores are first taken with the origin's distance from the base as ``sqrt(x * x + y * y)``, which
    differs from ``hypot`` by a few units in the last place; the ranking is then found among the spots whose
    score comes within twice a bound far above that difference of the ``needed``-th smallest, with their
    scores taken exactly: every spot of the exact ranking is among them (see :func:`_rank_exactly`).

    Args:
        free: (m,) the free spots, in the order (turn, row, column).
        on_axes: the grid's rows and columns are x and y: spot ``s`` is centred at ``(u[i], v[j])`` with
            ``i, j`` its row and column (``centre`` is then not read).
        u, v: the grid's row and column coordinates [m]; centre: (m, 2) the spots' centres [m].
        neighbours: (N, 2) the other objects' footprint centres [m].
        score, rel_x, rel_y, turns, turn, weights: the score terms' arguments, as :func:`spot_scores`.
        shares: (m,) the planner's samples expected on each spot.

    Returns:
        ranked (the spots, best first) and how many of them are the best.
    """
    n_row, n_col, n_near = u.shape[0], v.shape[0], neighbours.shape[0]
    cells = n_row * n_col
    n_turn = free.shape[0] // cells
    idx = np.empty(free.shape[0], np.int64)
    room = np.empty(free.shape[0])  # minus the capped gap of each free spot
    key = np.empty(free.shape[0])  # the scores with the distance from the base as a square root
    # on a part's grid every turn's spot in a cell has the cell's centre: its gap is found once (-1: not yet),
    # from the squared offsets per row and per column
    gaps = np.full(cells if on_axes else 0, -1.0)
    row_sq, col_sq = np.empty((n_row if on_axes else 0, n_near)), np.empty((n_col if on_axes else 0, n_near))
    if on_axes:
        for n in range(n_near):
            for i in range(n_row):
                dx = u[i] - neighbours[n, 0]
                row_sq[i, n] = dx * dx
            for j in range(n_col):
                dy = v[j] - neighbours[n, 1]
                col_sq[j, n] = dy * dy
    m, s = 0, 0
    for t in range(n_turn):
        for i in range(n_row):
            for j in range(n_col):
                if free[s]:
                    gap = math.inf
                    if on_axes:
                        cell = i * n_col + j
                        gap = gaps[cell]
                        if gap < 0:
                            gap = math.inf
                            for n in range(n_near):
                                gap = min(gap, row_sq[i, n] + col_sq[j, n])
                            gap = math.sqrt(gap)  # the root is monotone: the root of the least square is the least root
                            gaps[cell] = gap
                    else:
                        for n in range(n_near):
                            dx, dy = centre[s, 0] - neighbours[n, 0], centre[s, 1] - neighbours[n, 1]
                            gap = min(gap, math.sqrt(dx * dx + dy * dy))
                    x, y = _score_offsets(t, i, j, rel_x, rel_y)
                    room[m] = -min(gap, room_cap)
                    key[m] = room[m] + _score_of(s, math.sqrt(x * x + y * y), score, turns, turn, weights)
                    idx[m] = s
                    m += 1
                s += 1
    order = _rank_exactly(idx[:m], room[:m], key[:m], needed, score, rel_x, rel_y, turns, turn, weights, n_row,
                          n_col)
    ranked = idx[:m][order]
    total, count = 0.0, 0
    for r in range(ranked.shape[0]):
        total += shares[ranked[r]]
        if total > shortlist:
            break
        count += 1
    return ranked, max(1, count)


@numba.njit(cache=True, nogil=True)
def _rank_exactly(idx: np.ndarray, room: np.ndarray, key: np.ndarray, needed: int, score: np.ndarray,
                  rel_x: np.ndarray, rel_y: np.ndarray, turns: np.ndarray, turn: np.ndarray, weights: np.ndarray,
                  n_row: int, n_col: int) -> np.ndarray:
    """:func:`best_spots`' ranking (positions in ``idx``) from the scores ``key`` taken with the distance
    from the base as a square root, each within ``err`` of its exact score (``room`` plus :func:`spot_scores`).

    With ``b`` the ``needed``-th smallest exact score and ``a`` that of ``key``, ``|a - b| <= err``, so every
    spot scoring at most ``b`` has ``key <= a + 2 err``: the exact scores of those candidates, in index order,
    give the same ``needed``-th smallest score, the same spots up to it and the same stable order."""
    m = idx.shape[0]
    if needed >= m:
        cand = np.arange(m)
    else:
        a = np.partition(key, needed - 1)[needed - 1]
        # the scores are metres and weights of about one: their rounding differs by ~1e-15
        err = 1e-9 * (1.0 + abs(a))
        cand = np.flatnonzero(key <= a + 2 * err)
    exact = np.empty(cand.shape[0])
    for c in range(cand.shape[0]):
        exact[c] = room[cand[c]] + _spot_score(idx[cand[c]], score, rel_x, rel_y, turns, turn, weights, n_row, n_col)
    if needed >= cand.shape[0]:
        return cand[np.argsort(exact, kind="mergesort")]
    bound = np.partition(exact, needed - 1)[needed - 1]
    sel = np.flatnonzero(exact <= bound)
    return cand[sel[np.argsort(exact[sel], kind="mergesort")]]


@numba.njit(cache=True, nogil=True, inline="always")
def _score_offsets(t: int, i: int, j: int, rel_x: np.ndarray, rel_y: np.ndarray) -> tuple[float, float]:
    """The frame origin's offset from the base of spot (t, i, j), from offsets that broadcast to the grid."""
    x = rel_x[min(t, rel_x.shape[0] - 1), min(i, rel_x.shape[1] - 1), min(j, rel_x.shape[2] - 1)]
    y = rel_y[min(t, rel_y.shape[0] - 1), min(i, rel_y.shape[1] - 1), min(j, rel_y.shape[2] - 1)]
    return x, y


@numba.njit(cache=True, nogil=True, inline="always")
def _score_of(s: int, reach: float, score: np.ndarray, turns: np.ndarray, turn: np.ndarray,
              weights: np.ndarray) -> float:
    """:func:`spot_scores` of spot ``s`` with its frame origin ``reach`` from the base [m]."""
    return (score[min(s, score.shape[0] - 1)] + weights[0] * abs(reach - weights[1])) + weights[2] * abs(turns[turn[s]])


@numba.njit(cache=True, nogil=True)
def beside_keep(d: np.ndarray, lateral: np.ndarray, dists: np.ndarray, lats: np.ndarray, start: np.ndarray,
                centre: np.ndarray, origin: np.ndarray, offsets: np.ndarray, half: np.ndarray, lo: np.ndarray,
                hi: np.ndarray, table: np.ndarray, base: np.ndarray, need: float,
                weight: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    """The tests of an object's spots past a reference that need no other object and no distance from the
    base: the frame origin inside the workspace bounds and past the reference's by ``need``, the footprint
    inside the table's edges.

    Spot (t, i, j) puts the footprint centre at ``centre + (start[t] + dists[i]) d + lats[j] lateral``,
    each coordinate computed as the array expression of :mod:`samplehd.world.free_spot` did, on the axes it
    depends on (a term whose direction component is 0 left out; the distance past the reference along a
    slanted direction is the product ``a0 * b0 + a1 * b1``, as :func:`samplehd.fixedmath.matmul`).

    Args:
        d, lateral: (2,) the direction and its lateral; dists, lats: the rows' distances and the columns'
            lateral offsets [m]; start: (t,) the distance of the first row per turn (both extents and the
            margin) [m].
        centre, origin: (2,) the reference's footprint centre and frame origin [m].
        offsets: (t, 2) footprint centre minus frame origin per turn; half: (t, 2) the turned footprint's
            world-axis half sizes [m].
        lo, hi: (2,) the workspace bounds for the origin; table: (2,) the table's half sizes less its edge;
            base: (2,) the robot base [m]; need: how far past the reference's origin [m].
        weight: (m,) the spots' weights, in the order (turn, row, column).

    Returns:
        keep (t, r, c); the footprint centres' x and y and the origins' offsets from the base, x and y,
        each (t, r or 1, c or 1) as it depends on the row and column; and the kept spots' weights summed
        left to right (not numpy's sum: for deciding far from a bound only).
    """
    n_turn, n_row, n_col = start.shape[0], dists.shape[0], lats.shape[0]
    cx, ox, rx, okx = _beside_axis(0, d, lateral, dists, lats, start, centre, offsets, half, lo, hi, table, base)
    cy, oy, ry, oky = _beside_axis(1, d, lateral, dists, lats, start, centre, offsets, half, lo, hi, table, base)
    aligned = d[0] == 0 or d[1] == 0
    axis = 0 if d[0] != 0 else 1
    keep = np.empty((n_turn, n_row, n_col), np.bool_)
    kept = 0.0
    for t in range(n_turn):
        for i in range(n_row):
            for j in range(n_col):
                i0, j0 = min(i, okx.shape[1] - 1), min(j, okx.shape[2] - 1)
                i1, j1 = min(i, oky.shape[1] - 1), min(j, oky.shape[2] - 1)
                ok = okx[t, i0, j0] and oky[t, i1, j1]
                if ok:
                    x, y = ox[t, i0, j0], oy[t, i1, j1]
                    if aligned:
                        ok = ((x if axis == 0 else y) - origin[axis]) * d[axis] >= need
                    else:
                        ok = (x - origin[0]) * d[0] + (y - origin[1]) * d[1] >= need
                keep[t, i, j] = ok
                if ok:
                    kept += weight[(t * n_row + i) * n_col + j]
    return keep, cx, cy, rx, ry, kept


@numba.njit(cache=True, nogil=True)
def _beside_axis(a: int, d: np.ndarray, lateral: np.ndarray, dists: np.ndarray, lats: np.ndarray,
                 start: np.ndarray, centre: np.ndarray, offsets: np.ndarray, half: np.ndarray, lo: np.ndarray,
                 hi: np.ndarray, table: np.ndarray,
                 base: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`beside_keep` on coordinate ``a`` alone: the centres, origins, origins less the base and the
    tests on them, (t, r or 1, c or 1) as the coordinate depends on the row and column."""
    n_turn = start.shape[0]
    nr = dists.shape[0] if d[a] != 0 else 1
    nc = lats.shape[0] if lateral[a] != 0 else 1
    v = np.empty((n_turn, nr, nc))
    orig = np.empty((n_turn, nr, nc))
    rel = np.empty((n_turn, nr, nc))
    ok = np.empty((n_turn, nr, nc), np.bool_)
    for t in range(n_turn):
        for i in range(nr):
            along = start[t] + dists[i]
            for j in range(nc):
                c = centre[a]
                if d[a] != 0:
                    c = c + along * d[a]
                if lateral[a] != 0:
                    c = c + lats[j] * lateral[a]
                o = c - offsets[t, a]
                h = half[t, a]
                ok[t, i, j] = (o >= lo[a]) and (o <= hi[a]) and (c - h >= -table[a]) and (c + h <= table[a])
                v[t, i, j] = c
                orig[t, i, j] = o
                rel[t, i, j] = o - base[a]
    return v, orig, rel, ok


@numba.njit(cache=True, nogil=True)
def clearance(u: np.ndarray, v: np.ndarray, centres: np.ndarray, rots: np.ndarray, halves: np.ndarray,
              grow: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How far each point of a grid on the axes lies from the scene's footprints: per point (``u[i]``,
    ``v[j]``), the squared distance to the nearest rectangle (centres ``centres``, rotations ``rots``, half
    sizes ``halves + grow``), which one that is, and the squared distance to the next nearest.

    Returns:
        nearest (r, c), which (r, c) (-1: no rectangle), next (r, c) (inf where there is none).
    """
    n_row, n_col = u.shape[0], v.shape[0]
    nearest = np.full((n_row, n_col), math.inf)
    which = np.full((n_row, n_col), -1, np.int64)
    second = np.full((n_row, n_col), math.inf)
    for m in range(centres.shape[0]):
        hx, hy = halves[m, 0] + grow, halves[m, 1] + grow
        r00, r01, r10, r11 = rots[m, 0, 0], rots[m, 0, 1], rots[m, 1, 0], rots[m, 1, 1]
        for i in range(n_row):
            dx = u[i] - centres[m, 0]
            for j in range(n_col):
                dy = v[j] - centres[m, 1]
                ex = max(abs(dx * r00 + dy * r10) - hx, 0.0)
                ey = max(abs(dx * r01 + dy * r11) - hy, 0.0)
                d = ex * ex + ey * ey
                if d < nearest[i, j]:
                    second[i, j] = nearest[i, j]
                    nearest[i, j], which[i, j] = d, m
                elif d < second[i, j]:
                    second[i, j] = d
    return nearest, which, second


@numba.njit(cache=True, nogil=True)
def clear_points(nearest: np.ndarray, which: np.ndarray, second: np.ndarray, k: int, least: float) -> int:
    """How many points of :func:`clearance`'s grid lie at a squared distance of at least ``least`` from every
    rectangle but k."""
    count = 0
    for i in range(nearest.shape[0]):
        for j in range(nearest.shape[1]):
            d = second[i, j] if which[i, j] == k else nearest[i, j]
            if d >= least:
                count += 1
    return count


@numba.njit(cache=True, nogil=True)
def weight_sum(mask: np.ndarray, weight: np.ndarray) -> tuple[float, bool]:
    """The weights of the spots in ``mask`` summed left to right (not numpy's sum: for deciding far from a
    bound only), and whether there is any."""
    total, found = 0.0, False
    for j in range(mask.shape[0]):
        if mask[j]:
            total += weight[j]
            found = True
    return total, found


@numba.njit(cache=True, nogil=True, inline="always")
def _spot_score(s: int, score: np.ndarray, rel_x: np.ndarray, rel_y: np.ndarray, turns: np.ndarray,
                turn: np.ndarray, weights: np.ndarray, n_row: int, n_col: int) -> float:
    """:func:`spot_scores` of spot ``s``."""
    t, rest = divmod(s, n_row * n_col)
    i, j = divmod(rest, n_col)
    x, y = _score_offsets(t, i, j, rel_x, rel_y)
    return _score_of(s, math.hypot(x, y), score, turns, turn, weights)


@numba.njit(cache=True, nogil=True)
def spot_scores(score: np.ndarray, rel_x: np.ndarray, rel_y: np.ndarray, turns: np.ndarray, turn: np.ndarray,
                weights: np.ndarray, n_row: int, n_col: int) -> np.ndarray:
    """The planner's score terms of a grid's spots that do not depend on the neighbours, as the array
    expression ``score + w0 * |hypot(rel_x, rel_y) - w1| + w2 * |turns[turn]|`` gives them.

    Args:
        score: (m,) or (1,) a score of each spot (or of all) to add to [-].
        rel_x, rel_y: the frame origins' offsets from the robot base, (t, r or 1, c or 1) [m].
        turns: (t,) the turns [rad]; turn: (m,) each spot's.
        weights: the reach weight, the comfortable reach [m] and the turn weight [1/rad].
        n_row, n_col: the grid's rows and columns.

    Returns:
        (m,) the scores, spots in the order (turn, row, column).
    """
    out = np.empty(turn.shape[0])
    for s in range(turn.shape[0]):
        out[s] = _spot_score(s, score, rel_x, rel_y, turns, turn, weights, n_row, n_col)
    return out


@numba.njit(cache=True, nogil=True)
def uncovered_weight(keep: np.ndarray, first: np.ndarray, last: np.ndarray, use: np.ndarray, count: int,
                     weight: np.ndarray) -> tuple[float, bool]:
    """:func:`weight_sum` of :func:`uncovered`'s spots (its arguments but the weights), without keeping them."""
    return weight_sum(uncovered(keep, first, last, use, count), weight)


@numba.njit(cache=True, nogil=True)
def spot_options(free: np.ndarray, weight: np.ndarray, samples: float, min_hits: float, decided: bool,
                 on_axes: bool, u: np.ndarray, v: np.ndarray, centre: np.ndarray, neighbours: np.ndarray,
                 score: np.ndarray, rel_x: np.ndarray, rel_y: np.ndarray, turns: np.ndarray, turn: np.ndarray,
                 weights: np.ndarray, shares: np.ndarray, room_cap: float, needed: int, shortlist: float,
                 spread: float, most: int, offsets: np.ndarray, base: np.ndarray, sure_lo: float,
                 sure_hi: float) -> tuple[int, np.ndarray, int, np.ndarray, bool]:
    """The spots the planner may pick among the free ones, in one call: whether enough of its samples land
    on them, the best ranked (:func:`best_spots`), a few far apart (:func:`farthest_picks` over position and
    ``spread`` times the turn) and whether their frame origins all lie from the base within
    [``sure_lo``, ``sure_hi``].

    Args:
        free: (m,) the free spots; weight: (m,) their weights; samples, min_hits: the planner's first-try
            samples and the fewest expected on free spots.
        decided: the sum of weights is known not to fall short (skip that test).
        on_axes ... shortlist: as :func:`best_spots`.
        spread: weight of a turn against a distance [m/rad]; most: how many picks at most.
        offsets: (t, 2) footprint centre minus frame origin per turn [m]; base: (2,) the robot base [m].
        sure_lo, sure_hi: the distances from the base the picks' origins are tested against [m].

    Returns:
        status (0: too few samples land on free spots, no options; 1: the weights' sum is too near the bound
        to decide in this order, the caller decides and calls again with ``decided``; 2: ranked), the ranked
        spots, how many are the best, the picks (positions among the best) and whether every pick's origin
        lies within the bounds (status 2 only).
    """
    none = np.zeros(0, np.int64)
    if not decided:
        total, _ = weight_sum(free, weight)  # as FreeSpots._below decides it
        value = samples * total
        if abs(value - min_hits) <= 1e-15 * samples * free.shape[0] + 1e-12:
            return 1, none, 0, none, False
        if value < min_hits:
            return 0, none, 0, none, False
    ranked, count = best_spots(free, on_axes, u, v, centre, neighbours, score, rel_x, rel_y, turns, turn, weights,
                               shares, room_cap, needed, shortlist)
    if ranked.shape[0] == 0:  # (only where no samples are asked for)
        return 0, none, 0, none, False
    where = np.empty((count, 3))
    for r in range(count):
        s = ranked[r]
        where[r, 0], where[r, 1] = centre[s, 0], centre[s, 1]
        where[r, 2] = spread * turns[turn[s]]
    picks = farthest_picks(where, most)
    sure = True
    for p in range(picks.shape[0]):
        s = ranked[picks[p]]
        t = turn[s]
        reach = math.hypot((centre[s, 0] - offsets[t, 0]) - base[0], (centre[s, 1] - offsets[t, 1]) - base[1])
        sure = sure and reach >= sure_lo and reach <= sure_hi
    return 2, ranked, count, picks, sure


@numba.njit(cache=True, nogil=True)
def option_counts(free: np.ndarray, rt: np.ndarray, half: np.ndarray, centre: np.ndarray, rots: np.ndarray,
                  turn: np.ndarray, at: np.ndarray, at_half: np.ndarray, grow: float, base: np.ndarray,
                  grid_axes: np.ndarray, u: np.ndarray, lo: float, width: float,
                  count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The runs an object put on each of its options ``at`` blocks on the next object's grid, and the next
    object's free spots each leaves per turn, in one call: :func:`rect_runs` of the rectangles (centres
    ``centre[at]``, rotations ``rots[turn[at]]``, half sizes ``at_half``) on every row, then
    :func:`counts_outside` of ``free``.

    Args:
        free: (m,) the next object's free spots; rt: (t, 2, 2) its rotation after each turn; half: (2,) its
            half sizes [m].
        centre, rots, turn: the placed object's spots' centres (M, 2) [m], rotations per turn (T, 2, 2) and
            turns (M,); at: (R,) the options; at_half: (2,) the placed object's half sizes [m].
        grow, base, grid_axes, u, lo, width, count: as :func:`rect_runs` (the next object's grid).

    Returns:
        first, last: (R, t, r) the runs; counts: (R, t) the free spots outside each option's runs per turn.
    """
    n = at.shape[0]
    centres, rects, halves = np.empty((n, 2)), np.empty((n, 2, 2)), np.empty((n, 2))
    for a in range(n):
        s = at[a]
        centres[a, 0], centres[a, 1] = centre[s, 0], centre[s, 1]
        rects[a] = rots[turn[s]]
        halves[a, 0], halves[a, 1] = at_half[0], at_half[1]
    first, last = rect_runs(rt, half, rects, halves, centres, np.arange(n), grow, base, grid_axes, u, 0, u.shape[0],
                            lo, width, count)
    return first, last, counts_outside(free, first, last, count)


@numba.njit(cache=True, nogil=True)
def in_annulus(keep: np.ndarray, rel_x: np.ndarray, rel_y: np.ndarray, reach_min: float, reach_max: float,
               sq_lo: float, sq_hi: float, sure_lo: float, sure_hi: float, gap_lo: float, gap_hi: float) -> None:
    """Keep (in place) only the spots with ``reach_min <= hypot(rel_x, rel_y) <= reach_max``, decided on the
    squared distance ``rel_x**2 + rel_y**2`` where it lies surely inside [``sure_lo``, ``sure_hi``] or outside,
    and by ``hypot`` (the C library's, as ``np.hypot``) where it lies within ``gap_lo`` of ``sq_lo`` or
    ``gap_hi`` of ``sq_hi``: the same answers.

    Args:
        keep: (t, r, c) spots; rel_x, rel_y: offsets from the centre of the annulus, each of a shape that
            broadcasts to keep's (its axes of length 1 repeat) [m].
    """
    n_turn, n_row, n_col = keep.shape
    last_x, last_y = rel_x.shape[2] - 1, rel_y.shape[2] - 1
    for t in range(n_turn):
        tx, ty = min(t, rel_x.shape[0] - 1), min(t, rel_y.shape[0] - 1)
        for i in range(n_row):
            row = keep[t, i]
            xs, ys = rel_x[tx, min(i, rel_x.shape[1] - 1)], rel_y[ty, min(i, rel_y.shape[1] - 1)]
            for j in range(n_col):
                if not row[j]:
                    continue
                x, y = xs[min(j, last_x)], ys[min(j, last_y)]
                sq = x * x + y * y
                if abs(sq - sq_lo) < gap_lo or abs(sq - sq_hi) < gap_hi:
                    reach = math.hypot(x, y)
                    row[j] = reach >= reach_min and reach <= reach_max
                elif not (sq >= sure_lo and sq <= sure_hi):
                    row[j] = False


@numba.njit(cache=True, nogil=True)
def blockers(keep: np.ndarray, base: np.ndarray, grid_axes: np.ndarray, u: np.ndarray, v: np.ndarray,
             centre: np.ndarray, radius: np.ndarray, k: int, rt: np.ndarray, half: np.ndarray, rots: np.ndarray,
             halves: np.ndarray, grow: float, lo: float, width: float,
             count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The scene's objects that may block a spot of object k in ``keep`` and the runs they block, in one call:
    :func:`near_objects`, then :func:`rect_runs` of those objects (rotations ``rots``, half sizes ``halves``,
    footprint centres ``centre``) on the rows holding spots in ``keep`` only, and of those on the rows each
    object can reach (``radius``: the half diagonals grown by the margin); no run on the others.

    Returns:
        near (b,), first and last (b, t, r).
    """
    near, r0, r1 = near_objects(keep, rt.shape[0], base, grid_axes, u, v, centre, radius, k)
    reach = radius[k] + radius + 1e-9  # (with room for the rounding of the projections, as near_objects)
    first, last = _rect_runs(rt, half, rots, halves, centre, near, grow, base, grid_axes, u, r0, r1, lo, width, count,
                             reach)
    return near, first, last


@numba.njit(cache=True, nogil=True)
def blocked_weight(keep: np.ndarray, base: np.ndarray, grid_axes: np.ndarray, u: np.ndarray, v: np.ndarray,
                   centre: np.ndarray, radius: np.ndarray, k: int, rt: np.ndarray, half: np.ndarray,
                   rots: np.ndarray, halves: np.ndarray, grow: float, lo: float, width: float, count: int,
                   weight: np.ndarray) -> tuple[float, bool]:
    """:func:`uncovered_weight` of the spots in ``keep`` outside the runs of every object :func:`blockers`
    finds near (its arguments, then the spots' weights), in one call: where the scene's objects all stand
    where they are, the weights of object k's free spots summed left to right, and whether there is any."""
    near, first, last = blockers(keep, base, grid_axes, u, v, centre, radius, k, rt, half, rots, halves, grow, lo,
                                 width, count)
    return uncovered_weight(keep, first, last, np.ones(near.shape[0], np.bool_), count, weight)
