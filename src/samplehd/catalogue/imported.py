"""Read the geometry of an imported class (written by :mod:`.importer`): a class of the user registry
or of the shipped pack (``data/imported_pack``, see :func:`samplehd.catalogue.loader.pack_classes`).

Reading needs numpy and scipy only (convex hulls of the stored pieces), so a scene that holds an
imported class compiles without the ``mesh`` extra; only importing a mesh needs it.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from samplehd.catalogue.shape import (
    GraspSite,
    ObjectGeometry,
    TopSurface,
    convex_pieces,
    mesh_area,
    planar_texcoords,
    read_mesh_arrays,
)
from samplehd.errors import AssetError

__all__ = ["load_imported_geometry"]


def load_imported_geometry(path: str | Path, sha256: str) -> ObjectGeometry:
    """Load the geometry of an imported class from its ``geometry.npz`` and ``geometry.json``.

    Args:
        path: the ``geometry.npz`` file.
        sha256: its content hash, as the class entry records it (``digest``).

    Raises:
        AssetError: the files are missing, damaged or the mesh file does not match ``sha256``.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise AssetError(f"{path}: cannot read the imported geometry ({exc.strerror}); re-import the mesh") from None
    if hashlib.sha256(data).hexdigest() != sha256:
        raise AssetError(f"{path}: content does not match its digest in class.json; restore the file or "
                         "re-import the mesh")
    try:
        vertices, faces, counts, points = read_mesh_arrays(str(path))
        meta = json.loads(path.with_suffix(".json").read_text())
        t = meta["top"]
        top = TopSurface(t["height"], tuple(t["center"]), tuple(t["half_extents"]), False, bool(t["flat"]))
        grasps = tuple(
            GraspSite(g["name"], tuple(g["position"]), tuple(g["approach"]), tuple(g["closing"]), g["width"])
            for g in meta["grasps"]
        )
        volume = float(meta["volume"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise AssetError(f"{path}: damaged imported geometry ({exc}); re-import the mesh") from None
    return ObjectGeometry(
        vertices=vertices,
        faces=faces,
        texcoords=planar_texcoords(vertices),
        pieces=convex_pieces(counts, points),
        volume=volume,
        area=mesh_area(vertices, faces),
        top=top,
        opening=None,
        grasps=grasps,
    )
