"""Read the geometry of an imported class from the user registry (written by :mod:`.importer`).

Reading needs trimesh (convex hulls of the stored pieces, mesh area), which comes with the ``mesh``
extra; built-in classes never load this code path.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from samplehd.catalogue.shape import (
    CollisionPiece,
    GraspSite,
    ObjectGeometry,
    TopSurface,
    planar_texcoords,
    read_mesh_arrays,
)
from samplehd.errors import AssetError, require_extra

__all__ = ["load_imported_geometry"]


def load_imported_geometry(path: str | Path) -> ObjectGeometry:
    """Load the geometry of an imported class from its ``geometry.npz`` and ``geometry.json``.

    Raises:
        AssetError: the files are missing or damaged (re-import the mesh).
        MissingExtraError: trimesh is not installed (``pip install 'samplehd[mesh]'``).
    """
    trimesh = require_extra("trimesh", "mesh", "imported object classes")
    path = Path(path)
    try:
        vertices, faces, counts, points = read_mesh_arrays(str(path))
        meta = json.loads(path.with_suffix(".json").read_text())
        pieces = []
        for pts in np.split(points, np.cumsum(counts)[:-1]):
            hull = trimesh.convex.convex_hull(pts)
            pieces.append(
                CollisionPiece(
                    "mesh",
                    (0.0, 0.0, 0.0),
                    (1.0, 0.0, 0.0, 0.0),
                    (0.0, 0.0, 0.0),
                    np.asarray(hull.vertices, np.float64),
                    float(hull.volume),
                )
            )
        t = meta["top"]
        top = TopSurface(t["height"], tuple(t["center"]), tuple(t["half_extents"]), False, bool(t["flat"]))
        grasps = tuple(
            GraspSite(g["name"], tuple(g["position"]), tuple(g["approach"]), tuple(g["closing"]), g["width"])
            for g in meta["grasps"]
        )
        mesh = trimesh.Trimesh(vertices, faces, process=False)
        area = float(mesh.area)
        volume = float(meta["volume"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise AssetError(f"{path}: damaged imported geometry ({exc}); re-import the mesh") from None
    return ObjectGeometry(
        vertices=vertices,
        faces=faces,
        texcoords=planar_texcoords(vertices),
        pieces=tuple(pieces),
        volume=volume,
        area=area,
        top=top,
        opening=None,
        grasps=grasps,
    )
