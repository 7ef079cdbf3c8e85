"""Spatial relationships between scene objects, computed CLEVR-style from their positions."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from samplehd.fixedmath import matmul
from samplehd.world.layout import DIRECTIONS

__all__ = ["DEFAULT_RELATION_MARGIN", "RELATIONS", "compute_relationships"]

# The four relations CLEVR stores in a scene's "relationships" (above/below are not relations).
RELATIONS = ("left", "right", "front", "behind")

# An object must be this far past another along a direction to count as in that direction [m].
DEFAULT_RELATION_MARGIN = 0.02


def _coords(objects: Sequence[Mapping[str, Any]] | np.ndarray) -> np.ndarray:
    if isinstance(objects, np.ndarray):
        coords = np.asarray(objects, dtype=float)
    else:
        coords = np.array([o["3d_coords"] for o in objects], dtype=float).reshape(len(objects), -1)
    if coords.ndim != 2 or (len(coords) and coords.shape[1] not in (2, 3)):
        raise ValueError(f"expected N x 3 coordinates, got shape {coords.shape}")
    if coords.shape[1] == 2:
        coords = np.concatenate([coords, np.zeros((len(coords), 1))], axis=1)
    return coords


def compute_relationships(
    objects: Sequence[Mapping[str, Any]] | np.ndarray,
    directions: Mapping[str, Sequence[float]] = DIRECTIONS,
    margin: float = DEFAULT_RELATION_MARGIN,
) -> dict[str, list[list[int]]]:
    """Return CLEVR ``relationships``: for each relation, per object ``i`` the sorted ``j`` in it.

    Object ``j`` is in direction ``r`` of object ``i`` when the offset ``coords[j] - coords[i]``
    projected on the unit vector ``directions[r]`` exceeds ``margin``, exactly as CLEVR computes it.

    Args:
        objects: scene objects (dicts with ``3d_coords``) or an ``(N, 3)`` array of positions [m].
        directions: unit vectors per direction name; only left/right/front/behind are used.
        margin: smallest projected offset that counts [m].

    Returns:
        ``{relation: [[j, ...] for each object i]}`` for relation in left, right, front, behind.
    """
    coords = _coords(objects)
    out: dict[str, list[list[int]]] = {}
    for name in RELATIONS:
        d = np.asarray(directions[name], dtype=float)[: coords.shape[1]]
        # offset[i, j] = (coords[j] - coords[i]) . d, exactly as CLEVR computes it
        offset = matmul(coords[None, :, :] - coords[:, None, :], d)
        np.fill_diagonal(offset, -np.inf)
        out[name] = [np.flatnonzero(row > margin).tolist() for row in offset]
    return out
