"""Geometry of the vendored meshes of the ``shop-vrb`` catalogue (``data/shop_vrb``).

Each variant's ``geometry`` entry in ``data/shop_vrb/classes.json`` names a ``.npz`` file of plain
arrays (read with ``allow_pickle=False``: data, never code) and carries the facts measured when the
mesh was vendored (``scripts/vendor_shop_vrb.py``)::

    {"kind": "mesh", "file": "mug_shopvrb1.npz", "sha256": "...",
     "top": {"height", "center", "half_extents", "round", "flat"},
     "opening": {"radius", "floor_height", "depth", "center"} | null,
     "grasps": [{"name", "position", "approach", "closing", "width", "axisymmetric"}, ...],
     "volume"?: enclosed volume [m^3] (closed things with contents: the mesh is a thin shell)}

The file holds ``vertices`` (n, 3) [m] and ``faces`` (m, 3) of the closed visual mesh in the object
frame (z up, resting on z = 0, handles towards +x), and the convex collision pieces as
``piece_counts`` (k,) and ``piece_points`` (sum of counts, 3) [m]. Reading needs numpy and scipy
only (no trimesh): the built-in catalogues never depend on the ``mesh`` extra.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from samplehd.catalogue.schema import Field
from samplehd.catalogue.shape import (
    GraspSite,
    ObjectGeometry,
    Opening,
    TopSurface,
    convex_pieces,
    mesh_area,
    read_mesh_arrays,
)
from samplehd.errors import AssetError

__all__ = ["MeshSpec", "load_vendored_geometry", "mesh_texcoords", "parse_mesh"]

_UV_REPEAT = 0.3  # length covered by one copy of a material texture [m]


@dataclass(frozen=True)
class MeshSpec:
    """A vendored mesh and its measured facts at real-world size.

    Attributes:
        path: the ``.npz`` file.
        sha256: its content hash (checked on load).
        top: surface another object rests on.
        opening: inside of the container, or None.
        grasps: grasp sites, best first.
        volume: volume the object encloses, where its mesh is a hollow shell [m^3]; None: the mesh's.
    """

    path: str
    sha256: str
    top: TopSurface
    opening: Opening | None
    grasps: tuple[GraspSite, ...]
    volume: float | None = None


def parse_mesh(f: Field, base_dir: Path | None = None) -> MeshSpec:
    """Validate a ``{"kind": "mesh", ...}`` geometry entry.

    Raises:
        AssetError: a missing or unknown key, a bad value, or a missing file (one line naming both).
    """
    m = f.mapping(["kind", "file", "sha256", "top", "opening", "grasps"], ["volume"])
    path = Path(m["file"].string())
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    if not path.is_file():
        raise m["file"].fail(f"mesh file {path} does not exist")
    t = m["top"].mapping(["height", "center", "half_extents", "round", "flat"])
    c, h = t["center"].numbers(2, -1.0, 1.0), t["half_extents"].numbers(2, 0.0, 1.0)
    top = TopSurface(t["height"].number(0.0, 1.0), (c[0], c[1]), (h[0], h[1]), t["round"].boolean(),
                     t["flat"].boolean())
    opening = None
    if m["opening"].value is not None:
        o = m["opening"].mapping(["radius", "floor_height", "depth", "center"])
        oc = o["center"].numbers(2, -1.0, 1.0)
        opening = Opening(o["radius"].positive(), o["floor_height"].number(0.0, 1.0), o["depth"].positive(),
                          (oc[0], oc[1]))
    grasps = []
    for g in m["grasps"].sequence(1):
        gm = g.mapping(["name", "position", "approach", "closing", "width", "axisymmetric"])
        p, a, cl = (gm[k].numbers(3, -1.0, 1.0) for k in ("position", "approach", "closing"))
        grasps.append(GraspSite(gm["name"].choice(["body", "rim", "handle", "edge"]), (p[0], p[1], p[2]),
                                (a[0], a[1], a[2]), (cl[0], cl[1], cl[2]), gm["width"].positive(),
                                gm["axisymmetric"].boolean()))
    volume = m["volume"].number(1e-7, 0.1) if "volume" in m else None
    return MeshSpec(str(path), m["sha256"].string(), top, opening, tuple(grasps), volume)


def mesh_texcoords(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Per-vertex texture coordinates by box projection: each vertex takes the plane facing its normal.

    A vertex whose (area-weighted) normal points mostly along z is mapped from (x, y), along x from
    (y, z), along y from (x, z), so wood grain and brushed metal run along the surface on every side
    of a board, a box or a can instead of smearing across the sides as one planar map does.

    Args:
        vertices: (n, 3) points [m].
        faces: (m, 3) triangles.

    Returns:
        (n, 2) coordinates, one texture copy per ``_UV_REPEAT`` metres.
    """
    v = np.asarray(vertices, np.float64)
    tri = v[np.asarray(faces, np.int64)]
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # area-weighted face normals
    vn = np.zeros_like(v)
    for k in range(3):
        np.add.at(vn, faces[:, k], fn)
    axis = np.argmax(np.abs(vn), axis=1)
    uv = np.where(axis[:, None] == 2, v[:, [0, 1]], np.where(axis[:, None] == 0, v[:, [1, 2]], v[:, [0, 2]]))
    return uv / _UV_REPEAT


def load_vendored_geometry(spec: MeshSpec) -> ObjectGeometry:
    """Read a vendored mesh and its convex pieces into an :class:`ObjectGeometry`.

    Raises:
        AssetError: the file is missing, damaged or does not match its recorded hash.
    """
    path = Path(spec.path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise AssetError(f"{path}: cannot read the vendored mesh ({exc.strerror})") from None
    if hashlib.sha256(data).hexdigest() != spec.sha256:
        raise AssetError(f"{path}: content does not match its sha256 in classes.json; restore the file")
    try:
        vertices, faces, counts, points = read_mesh_arrays(str(path))
    except (OSError, ValueError, KeyError) as exc:
        raise AssetError(f"{path}: damaged vendored mesh ({exc})") from None
    tri = vertices[faces]
    volume = float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum()) / 6.0
    return ObjectGeometry(
        vertices=vertices,
        faces=faces,
        texcoords=mesh_texcoords(vertices, faces),
        pieces=convex_pieces(counts, points),
        volume=spec.volume if spec.volume is not None else abs(volume),
        area=mesh_area(vertices, faces),
        top=spec.top,
        opening=spec.opening,
        grasps=spec.grasps,
    )
