"""Triangle meshes of boxes and cylinders, several merged into one mesh.

The mesh look's hand is drawn as one mesh per body and material instead of a geom per shape: one draw
call instead of many, and a few dozen triangles per cylinder instead of MuJoCo's finely tessellated
built-in one. Every face corner carries its own normal, so box edges and cylinder rims stay sharp
while a cylinder's side is shaded smoothly. Faces wind counter-clockwise seen from outside.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco
import numpy as np

__all__ = ["SolidMesh"]


class SolidMesh:
    """Boxes and cylinders placed in one frame (a body's), merged into one triangle mesh."""

    def __init__(self) -> None:
        self._vertices: list[np.ndarray] = []
        self._normals: list[np.ndarray] = []
        self._faces: list[np.ndarray] = []
        self._count = 0

    def box(self, half: Sequence[float], pos: Sequence[float], quat: Sequence[float] = (1.0, 0.0, 0.0, 0.0)) -> None:
        """A box of half sizes ``half`` [m] centred at ``pos`` [m], turned by ``quat`` (w, x, y, z)."""
        vertices, normals, faces = [], [], []
        for axis in range(3):
            for sign in (1.0, -1.0):
                # u × v is the outward normal, so the corners below run counter-clockwise seen from outside
                u, v = (axis + 1) % 3, (axis + 2) % 3
                if sign < 0:
                    u, v = v, u
                normal = np.zeros(3)
                normal[axis] = sign
                base = len(vertices)
                for cu, cv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                    corner = half[axis] * normal
                    corner[u] = cu * half[u]
                    corner[v] = cv * half[v]
                    vertices.append(corner)
                    normals.append(normal)
                faces += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
        self._add(np.array(vertices), np.array(normals), np.array(faces), pos, quat)

    def cylinder(self, radius: float, half_length: float, pos: Sequence[float],
                 quat: Sequence[float] = (1.0, 0.0, 0.0, 0.0), segments: int = 24) -> None:
        """A cylinder of ``radius`` and ``half_length`` [m] along its z axis, centred at ``pos`` [m] and
        turned by ``quat`` (w, x, y, z); its round is ``segments`` flat sides."""
        angle = 2.0 * math.pi * np.arange(segments) / segments
        ring = np.column_stack([np.cos(angle), np.sin(angle), np.zeros(segments)])
        k = np.arange(segments)
        nxt = (k + 1) % segments
        # side: bottom ring 0..n-1, top ring n..2n-1, normals radial
        side_v = np.concatenate([radius * ring - [0, 0, half_length], radius * ring + [0, 0, half_length]])
        side_n = np.concatenate([ring, ring])
        side_f = np.concatenate([np.column_stack([k, nxt, segments + nxt]),
                                 np.column_stack([k, segments + nxt, segments + k])])
        vertices, normals, faces = [side_v], [side_n], [side_f]
        base = 2 * segments
        for sign in (1.0, -1.0):
            centre = np.array([[0.0, 0.0, sign * half_length]])
            vertices.append(np.concatenate([centre, radius * ring + centre]))
            normals.append(np.tile([0.0, 0.0, sign], (segments + 1, 1)))
            a, b = (k, nxt) if sign > 0 else (nxt, k)
            faces.append(base + np.column_stack([np.zeros(segments, dtype=int), 1 + a, 1 + b]))
            base += segments + 1
        self._add(np.concatenate(vertices), np.concatenate(normals), np.concatenate(faces), pos, quat)

    def _add(self, vertices: np.ndarray, normals: np.ndarray, faces: np.ndarray, pos: Sequence[float],
             quat: Sequence[float]) -> None:
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, np.asarray(quat, dtype=np.float64))
        rot = rot.reshape(3, 3)
        self._vertices.append(vertices @ rot.T + np.asarray(pos, dtype=np.float64))
        self._normals.append(normals @ rot.T)
        self._faces.append(faces + self._count)
        self._count += len(vertices)

    @property
    def vertices(self) -> np.ndarray:
        """(n, 3) float64 [m]."""
        return np.concatenate(self._vertices)

    @property
    def normals(self) -> np.ndarray:
        """(n, 3) float64, unit: each vertex's normal (no vertex is shared across an edge)."""
        return np.concatenate(self._normals)

    @property
    def faces(self) -> np.ndarray:
        """(m, 3) int32 vertex (and normal) indices."""
        return np.concatenate(self._faces).astype(np.int32)
