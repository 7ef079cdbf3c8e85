"""RRT-Connect in joint space (Kuffner & LaValle 2000) with shortcut smoothing, for the moves where
the straight joint-space path collides. OMPL has no Python wheel for this platform, so this small
planner stands in; it draws all randomness from an explicit generator."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from samplehd.errors import PlanningError

__all__ = ["rrt_connect", "shortcut"]


def _steer(a: np.ndarray, b: np.ndarray, step: float) -> np.ndarray:
    d = b - a
    n = float(np.max(np.abs(d)))
    return b.copy() if n <= step else a + d * (step / n)


def _edge_free(a: np.ndarray, b: np.ndarray, free: Callable[[np.ndarray], bool], res: float) -> bool:
    n = max(1, int(np.ceil(np.max(np.abs(b - a)) / res)))
    return all(free(a + s * (b - a)) for s in np.linspace(0.0, 1.0, n + 1)[1:])


def rrt_connect(
    start: np.ndarray,
    goal: np.ndarray,
    free: Callable[[np.ndarray], bool],
    lower: np.ndarray,
    upper: np.ndarray,
    rng: np.random.Generator,
    step: float = 0.25,
    resolution: float = 0.03,
    max_iterations: int = 1500,
) -> np.ndarray:
    """A collision-free joint path from ``start`` to ``goal``.

    Args:
        start: start configuration [rad].
        goal: goal configuration [rad].
        free: whether a configuration is collision-free.
        lower: lower sampling bound per joint [rad].
        upper: upper sampling bound per joint [rad].
        rng: random generator (the only source of randomness).
        step: largest extension per iteration (max-norm) [rad].
        resolution: collision-check resolution along edges [rad].
        max_iterations: iterations before giving up.

    Returns:
        Waypoints (k, 6) from start to goal, shortcut-smoothed.

    Raises:
        PlanningError: no path found within the iteration budget.
    """
    trees = [([np.asarray(start, float)], [-1]), ([np.asarray(goal, float)], [-1])]
    for it in range(max_iterations):
        q_rand = rng.uniform(lower, upper) if it % 5 else trees[1][0][0]
        ta, tb = trees
        # Extend tree a towards the sample.
        nodes_a, par_a = ta
        ia = int(np.argmin([np.max(np.abs(n - q_rand)) for n in nodes_a]))
        q_new = _steer(nodes_a[ia], q_rand, step)
        if not _edge_free(nodes_a[ia], q_new, free, resolution):
            trees.reverse()
            continue
        nodes_a.append(q_new)
        par_a.append(ia)
        # Connect tree b to the new node greedily.
        nodes_b, par_b = tb
        ib = int(np.argmin([np.max(np.abs(n - q_new)) for n in nodes_b]))
        while True:
            q_next = _steer(nodes_b[ib], q_new, step)
            if not _edge_free(nodes_b[ib], q_next, free, resolution):
                break
            nodes_b.append(q_next)
            par_b.append(ib)
            ib = len(nodes_b) - 1
            if np.max(np.abs(q_next - q_new)) < 1e-9:
                path_a = _trace(nodes_a, par_a, len(nodes_a) - 1)
                path_b = _trace(nodes_b, par_b, ib)
                path = path_a[::-1] + path_b[1:]
                if np.max(np.abs(path[0] - start)) > 1e-9:
                    path = path[::-1]
                return shortcut(np.array(path), free, rng, resolution)
        trees.reverse()
    raise PlanningError(f"RRT-Connect found no collision-free joint path in {max_iterations} iterations")


def _trace(nodes: list[np.ndarray], parents: list[int], i: int) -> list[np.ndarray]:
    out = []
    while i >= 0:
        out.append(nodes[i])
        i = parents[i]
    return out


def shortcut(
    path: np.ndarray, free: Callable[[np.ndarray], bool], rng: np.random.Generator, resolution: float = 0.03,
    rounds: int = 60,
) -> np.ndarray:
    """Shorten a joint path by replacing random sub-paths with straight segments where they are free."""
    pts = [p for p in path]
    for _ in range(rounds):
        if len(pts) < 3:
            break
        i, j = sorted(rng.choice(len(pts), size=2, replace=False))
        if j - i < 2:
            continue
        if _edge_free(pts[i], pts[j], free, resolution):
            pts = pts[: i + 1] + pts[j:]
    return np.array(pts)
