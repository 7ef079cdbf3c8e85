"""Import any mesh as a new object class: validate, clean, normalise, decompose, register.

``import_mesh`` reads an OBJ, STL, PLY or GLB file with trimesh (never unpickles or evaluates the
file), removes degenerate and duplicate faces (CoACD aborts the whole process on them), centres
the mesh on its footprint with the bottom on z = 0, scales it, splits it into convex pieces with
CoACD (cached in :func:`~samplehd.catalogue.registry.cache_dir` by file hash and parameters),
estimates grasp metadata from its principal axes, and writes the class to the user registry:

    <registry>/<name>/class.json     the class entry (same layout as one entry of classes.json)
    <registry>/<name>/geometry.npz   mesh + convex pieces (plain arrays, loaded with allow_pickle=False)
    <registry>/<name>/geometry.json  top surface, grasp sites, principal axes, source and parameters

The catalogue loader merges registered classes with the built-in ones, so scenes and instructions
can use the new class by name.
"""

from __future__ import annotations

import hashlib
import json
import math
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from samplehd.catalogue.geometry import GRIPPER_STROKE
from samplehd.catalogue.loader import CATALOGUES, load_catalogue, make_menu, pack_classes, parse_class
from samplehd.catalogue.model import Catalogue, ObjectClass
from samplehd.catalogue.registry import cache_dir, refresh, registry_dir
from samplehd.catalogue.schema import Field, is_identifier, read_json
from samplehd.catalogue.shape import GraspSite, TopSurface
from samplehd.errors import AssetError, require_extra
from samplehd.fileio import file_sha256
from samplehd.fixedmath import dot, matmul
from samplehd.schema import Config, bounded

# The mesh extra: importing meshes is the only thing that needs trimesh's readers.
trimesh = require_extra("trimesh", "mesh", "samplehd assets import")
require_extra("coacd", "mesh", "samplehd assets import")  # runs in a child process; fail here, in one line

__all__ = [
    "MESH_SUFFIXES",
    "ImportOptions",
    "decompose",
    "import_mesh",
    "normalise_mesh",
    "read_mesh",
]

MAX_NAME = 64  # characters of an imported class name

MESH_SUFFIXES = (".obj", ".stl", ".ply", ".glb")
_MIN_EXTENT, _MAX_EXTENT = 0.01, 1.0  # plausible tabletop object size [m]
_DECOMPOSITION_VERSION = 1
# Run as a script, not with -m: importing the samplehd.catalogue package would load MuJoCo for nothing.
_WORKER = Path(__file__).with_name(
    "coacd_worker.py"
)  # bump when the decomposition or cleaning changes (invalidates the cache)


@dataclass(frozen=True)
class ImportOptions(Config, section="ImportOptions"):
    """Parameters of an import (all part of the decomposition cache key).

    Attributes:
        scale: factor from file units to metres (e.g. 0.001 for millimetres); None: 1.
        size: target largest extent after scaling [m]; None keeps the scaled size.
        threshold: CoACD concavity threshold (smaller: more, tighter pieces) [-].
        max_pieces: most convex pieces CoACD may produce.
        seed: CoACD's random seed (same seed, same pieces).
    """

    scale: float | None = bounded(None, lo=0.0, lo_open=True)
    size: float | None = bounded(None, lo=_MIN_EXTENT, hi=_MAX_EXTENT, unit="m")
    threshold: float = bounded(0.05, lo=0.01, hi=1.0)
    max_pieces: int = bounded(16, lo=1, hi=64)
    seed: int = 0


def read_mesh(path: str | Path) -> trimesh.Trimesh:
    """Read a triangle mesh, with a one-line error for anything that is not one.

    Args:
        path: OBJ, STL, PLY or GLB file.

    Raises:
        AssetError: missing file, unsupported suffix, unreadable or empty mesh.
    """
    path = Path(path)
    if not path.is_file():
        raise AssetError(f"{path}: no such mesh file")
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise AssetError(f"{path}: unsupported mesh format {suffix or '(none)'}; use one of {', '.join(MESH_SUFFIXES)}")
    try:
        loaded = trimesh.load(str(path), file_type=suffix[1:], force="mesh", process=False)
    except Exception as exc:  # trimesh raises many types on malformed input
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise AssetError(f"{path}: cannot read the mesh ({msg[:120]})") from None
    if not isinstance(loaded, trimesh.Trimesh):
        raise AssetError(f"{path}: the file holds no triangle mesh (found {type(loaded).__name__})")
    if len(loaded.faces) == 0 or len(loaded.vertices) < 4:
        raise AssetError(f"{path}: the mesh is empty (no triangles)")
    if not np.all(np.isfinite(loaded.vertices)):
        raise AssetError(f"{path}: the mesh has non-finite vertex coordinates")
    return loaded


def clean_mesh(mesh: trimesh.Trimesh, source: str = "mesh") -> trimesh.Trimesh:
    """Merge duplicate vertices and remove degenerate and duplicate faces (CoACD aborts on them)."""
    mesh = trimesh.Trimesh(np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64), process=True)
    mesh.update_faces(mesh.nondegenerate_faces(height=1e-9))
    mesh.update_faces(mesh.unique_faces())
    mesh.remove_unreferenced_vertices()
    if len(mesh.faces) < 4:
        raise AssetError(f"{source}: fewer than 4 valid triangles remain after removing degenerate faces")
    if float(np.min(mesh.extents)) <= 0:
        raise AssetError(f"{source}: the mesh is flat (zero thickness along one axis); it cannot be a solid object")
    return mesh


def normalise_mesh(mesh: trimesh.Trimesh, options: ImportOptions, source: str = "mesh") -> trimesh.Trimesh:
    """Scale to metres, centre the footprint on the origin and put the bottom on z = 0.

    Raises:
        AssetError: the resulting size is outside [1 cm, 1 m] (suggests ``scale`` or ``size``).
    """
    m = mesh.copy()
    if options.scale is not None:
        m.apply_scale(options.scale)
    if options.size is not None:
        m.apply_scale(options.size / float(np.max(m.extents)))
    lo, hi = m.bounds
    m.apply_translation([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])
    ext = float(np.max(m.extents))
    if not (_MIN_EXTENT <= ext <= _MAX_EXTENT):
        raise AssetError(
            f"{source}: largest extent is {ext:.4g} m after scaling, outside [{_MIN_EXTENT}, {_MAX_EXTENT}] m; "
            "pass `scale` (e.g. 0.001 for millimetres) or `size` METRES"
        )
    return m


def decompose(mesh: trimesh.Trimesh, options: ImportOptions, source: str = "mesh") -> list[np.ndarray]:
    """Split a cleaned mesh into convex pieces with CoACD; returns each piece's hull vertices [m].

    CoACD runs in a child process (:mod:`samplehd.catalogue.coacd_worker`) so that a crash inside
    the C++ library becomes an :class:`AssetError` rather than the end of the caller.

    Raises:
        AssetError: CoACD failed on the mesh.
    """
    params = {"threshold": options.threshold, "max_pieces": options.max_pieces, "seed": options.seed}
    with tempfile.TemporaryDirectory(prefix="samplehd-coacd-") as tmp:
        src, dst = Path(tmp) / "in.npz", Path(tmp) / "out.npz"
        np.savez(src, vertices=np.asarray(mesh.vertices, np.float64), faces=np.asarray(mesh.faces, np.int32))
        proc = subprocess.run(
            [sys.executable, str(_WORKER), str(src), str(dst), json.dumps(params)],
            capture_output=True,
            text=True,
            check=False,
        )
        if proc.returncode != 0 or not dst.is_file():
            last = (proc.stderr.strip().splitlines() or [f"exit status {proc.returncode}"])[-1][:160]
            raise AssetError(
                f"{source}: convex decomposition (CoACD) failed: {last}; "
                "repair the mesh (make it closed and manifold) or try another `threshold`"
            )
        with np.load(dst, allow_pickle=False) as z:
            counts, points = z["counts"], z["points"]
    pieces = list(np.split(points, np.cumsum(counts)[:-1])) if len(counts) else []
    if not pieces:
        pieces = [np.asarray(mesh.convex_hull.vertices, np.float64)]
    return pieces


def _cached_decomposition(
    mesh: trimesh.Trimesh, key: str, options: ImportOptions, source: str
) -> tuple[list[np.ndarray], bool]:
    path = cache_dir() / "decompositions" / f"{key}.npz"
    if path.is_file():
        try:
            with np.load(path, allow_pickle=False) as z:
                counts = z["counts"]
                flat = z["points"]
            return list(np.split(flat, np.cumsum(counts)[:-1])), True
        except (OSError, ValueError, KeyError):
            pass  # a damaged cache entry is recomputed
    pieces = decompose(mesh, options, source)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, counts=np.array([len(p) for p in pieces]), points=np.vstack(pieces))
    tmp.replace(path)
    return pieces, False


def _principal_axes(vertices: np.ndarray) -> np.ndarray:
    """Horizontal principal axes (2 x 2, major first) of the footprint points."""
    xy = vertices[:, :2] - vertices[:, :2].mean(axis=0)
    x, y = xy[:, 0], xy[:, 1]
    sxx, syy, sxy = (float(np.add.reduce(a * b)) for a, b in ((x, x), (y, y), (x, y)))
    # the symmetric 2 x 2 second moment's eigenvectors in closed form (no LAPACK: same bits on every machine)
    theta = 0.5 * math.atan2(2.0 * sxy, sxx - syy)
    major = np.array([math.cos(theta), math.sin(theta)])
    return np.array([major, [-major[1], major[0]]])


def _grasp_metadata(mesh: trimesh.Trimesh) -> tuple[list[GraspSite], TopSurface, np.ndarray]:
    v = np.asarray(mesh.vertices)
    height = float(v[:, 2].max())
    axes = _principal_axes(v)
    sites = []
    z_grip = max(0.5 * height, height - 0.03)
    band = v[np.abs(v[:, 2] - z_grip) < max(0.1 * height, 0.005)]
    band = band if len(band) >= 3 else v
    for axis in axes[::-1]:  # minor axis first: the narrow way across fits the gripper best
        proj = matmul(band[:, :2], axis)
        width = float(proj.max() - proj.min())
        centre_xy = axis * (proj.max() + proj.min()) / 2 + (
            band[:, :2].mean(axis=0) - axis * dot(band[:, :2].mean(axis=0), axis)
        )
        sites.append(
            GraspSite(
                "body",
                (float(centre_xy[0]), float(centre_xy[1]), z_grip),
                (0.0, 0.0, -1.0),
                (float(axis[0]), float(axis[1]), 0.0),
                width,
            )
        )
    # A flat top: upward faces within 2 mm of the top covering at least 2 x 2 cm.
    normals = mesh.face_normals
    centres = mesh.triangles_center
    up = (normals[:, 2] > 0.95) & (centres[:, 2] > height - 0.002)
    area = float(mesh.area_faces[up].sum())
    if up.any():
        pts = mesh.triangles[up].reshape(-1, 3)
        lo, hi = pts[:, :2].min(axis=0), pts[:, :2].max(axis=0)
        top = TopSurface(
            height,
            (float(lo[0] + hi[0]) / 2, float(lo[1] + hi[1]) / 2),
            (float(hi[0] - lo[0]) / 2, float(hi[1] - lo[1]) / 2),
            False,
            area >= 4e-4,
        )
    else:
        top = TopSurface(height, (0.0, 0.0), (0.0, 0.0), False, False)
    return sites, top, axes


def import_mesh(
    path: str | Path,
    name: str,
    *,
    options: ImportOptions | None = None,
    materials: tuple[str, ...] = ("plastic",),
    colours: tuple[str, ...] | None = None,
    sizes: tuple[str, ...] | None = None,
    description: str | None = None,
    overwrite: bool = False,
    catalogue: Catalogue | None = None,
) -> tuple[ObjectClass, dict]:
    """Import a mesh file and register it as the object class ``name``.

    Args:
        path: OBJ, STL, PLY or GLB file.
        name: new class name (lower-case snake case; must not be a built-in or a shipped pack class).
        options: scaling and decomposition parameters.
        materials: materials the class's menu allows.
        colours: colours the menu allows (default: every colour that fits one of the materials).
        sizes: sizes the menu allows (default: all).
        description: a short noun phrase (default: "an imported <name>").
        overwrite: replace an already registered class of that name.
        catalogue: catalogue providing the vocabulary (default: built-in + registry).

    Returns:
        The registered class and a report dict (pieces, extents [m], volume [m^3], cached, seconds).

    Raises:
        AssetError: bad or reserved name, unreadable/empty mesh, implausible size, unknown colour/material/size.
    """
    t0 = time.perf_counter()
    options = options or ImportOptions()
    cat = catalogue or load_catalogue()
    if not is_identifier(name):
        raise AssetError(f"name={name!r}: use lower-case letters, digits and '_', starting with a letter", field="name")
    if len(name) > MAX_NAME:  # the registry's folder and file names carry it (255 bytes on most file systems)
        raise AssetError(f"name={name[:20]}... ({len(name)} characters): at most {MAX_NAME} characters", field="name")
    if any(name in load_catalogue(name=c).classes for c in CATALOGUES):
        raise AssetError(f"name={name!r} is a built-in class; choose another name", field="name")
    if name in pack_classes():
        raise AssetError(f"name={name!r} is a class of the shipped imported pack; choose another name",
                         field="name")
    target = registry_dir() / name
    if target.exists() and not overwrite:
        raise AssetError(f"name={name!r} is already registered ({target}); pass `overwrite` to replace it",
                         field="name")
    for m in materials:
        cat.material(m)
    for s in sizes or ():
        cat.size(s)
    for c in colours or ():
        cat.colour(c)
    colours = colours or tuple(c for c in cat.colours if any(cat.compatible(c, m) for m in materials))
    sizes = sizes or tuple(cat.sizes)
    make_menu(cat, colours, materials, sizes, Field(None, "command line", "menu"))

    src = Path(path)
    raw = read_mesh(src)
    mesh = normalise_mesh(clean_mesh(raw, str(src)), options, str(src))
    digest = file_sha256(src)
    params = json.dumps(
        {
            "v": _DECOMPOSITION_VERSION,
            "scale": options.scale,
            "size": options.size,
            "threshold": options.threshold,
            "max_pieces": options.max_pieces,
            "seed": options.seed,
        },
        sort_keys=True,
    )
    key = hashlib.sha256((digest + params).encode()).hexdigest()[:32]
    pieces, cached = _cached_decomposition(mesh, key, options, str(src))
    sites, top, axes = _grasp_metadata(mesh)
    volume = float(mesh.volume) if mesh.is_watertight and mesh.volume > 0 else None
    pieces_volume = float(sum(trimesh.convex.convex_hull(p).volume for p in pieces))

    graspable = any(s.width <= GRIPPER_STROKE for s in sites)
    entry = {
        "description": description or f"an imported {name.replace('_', ' ')}",
        "affordances": {
            "graspable": graspable,
            "handle_pickable": False,
            "container": False,
            "stackable_on": bool(top.flat),
            "stackable": True,
        },
        "mass": {"thin_walled": False},
        "variants": {"default": {"geometry": {"kind": "imported", "path": "geometry.npz", "digest": ""}}},
        "menu": {"colour": list(colours), "material": list(materials), "size": list(sizes)},
    }
    meta = {
        "source": str(src.resolve()),
        "source_sha256": digest,
        "options": json.loads(params),
        "volume": volume if volume is not None else pieces_volume,
        "principal_axes": axes.tolist(),
        "top": {
            "height": top.height,
            "center": list(top.center),
            "half_extents": list(top.half_extents),
            "flat": top.flat,
        },
        "grasps": [
            {
                "name": s.name,
                "position": list(s.position),
                "approach": list(s.approach),
                "closing": list(s.closing),
                "width": s.width,
            }
            for s in sites
        ],
    }
    registry = registry_dir()
    registry.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{name}-", dir=registry))
    try:
        np.savez_compressed(
            tmp / "geometry.npz",
            vertices=np.asarray(mesh.vertices, np.float64),
            faces=np.asarray(mesh.faces, np.int32),
            piece_counts=np.array([len(p) for p in pieces], np.int64),
            piece_points=np.vstack(pieces),
        )
        npz_digest = file_sha256(tmp / "geometry.npz")
        entry["variants"]["default"]["geometry"]["digest"] = npz_digest
        (tmp / "geometry.json").write_text(json.dumps(meta, indent=1) + "\n")
        (tmp / "class.json").write_text(json.dumps(entry, indent=1) + "\n")
        # Validate exactly as the loader will, before the class becomes visible.
        cls = parse_class(cat, read_json(tmp / "class.json"), name=name, imported=True, registry_dir=tmp)
        tmp.chmod(0o755)  # mkdtemp creates it private; the registry is plain user data
        if target.exists():
            shutil.rmtree(target)
        tmp.rename(target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    refresh()
    cls = load_catalogue((name,)).object_class(name)
    report = {
        "name": name,
        "pieces": len(pieces),
        "extents": [float(x) for x in mesh.extents],
        "volume": meta["volume"],
        "graspable": graspable,
        "cached": cached,
        "seconds": time.perf_counter() - t0,
        "registry": str(target),
    }
    return cls, report
