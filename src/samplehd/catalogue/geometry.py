"""Procedural object geometry: visual meshes, convex collision pieces and shape facts.

Every built-in class is described by a few numbers in ``data/classes.json`` (a geometry *kind* and
its parameters at real-world size, metres). This module turns those into an
:class:`ObjectGeometry`: a visual triangle mesh, a set of convex collision pieces made from the same
parameters (so nothing is decomposed at run time), and facts later stages need (top surface,
container opening, grasp sites).

Kinds:
    revolved: surface of revolution from a profile of stations ``[z, r_outer, r_inner]`` (r_inner 0
        = solid, > 0 = hollow; hollow stations form the top run, the first one is the inner floor),
        with an optional handle (``loop``: a half torus on the +x side; ``bar``: a straight tilted
        bar along +x). Hollow walls collide as convex sector pieces around the axis, so objects can
        go *into* bowls and mugs.
    box: a closed box (food boxes).
    tray: a box with a cavity (baking trays).
    board: a rounded slab with an optional handle and hole (chopping boards).
    cutlery: fork, spoon or knife lying flat along x.
    scissors: closed scissors lying flat along x.
    imported: a mesh registered with ``samplehd assets import`` (see :mod:`.importer`).
    mesh: a vendored mesh of the ``shop-vrb`` catalogue (see :mod:`.vendored`): the shape, its
        convex pieces and its facts (top surface, opening, grasp sites) come from the data files.

Object frame: z up, the object rests on z = 0, the revolution axis (or the bounding-box centre for
flat objects) is at x = y = 0. Handles point to +x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import manifold3d as mf
import numpy as np
from scipy.spatial import ConvexHull

from samplehd.catalogue.imported import load_imported_geometry
from samplehd.catalogue.schema import Field
from samplehd.catalogue.shape import (
    CollisionPiece,
    GraspSite,
    ObjectGeometry,
    Opening,
    TopSurface,
    planar_texcoords,
    scale_tuple,
)
from samplehd.catalogue.vendored import MeshSpec, load_vendored_geometry, parse_mesh
from samplehd.fixedmath import dot, norm
from samplehd.robot.constants import GRIPPER_STROKE

__all__ = [
    "GRIPPER_STROKE",
    "BarHandle",
    "BoardSpec",
    "BoxSpec",
    "CollisionPiece",
    "CutlerySpec",
    "GeometrySpec",
    "GraspSite",
    "ImportedSpec",
    "LoopHandle",
    "MeshSpec",
    "ObjectGeometry",
    "Opening",
    "RevolvedSpec",
    "ScissorsSpec",
    "TopSurface",
    "TraySpec",
    "build_geometry",
    "parse_geometry",
]

_SEGMENTS = 48  # circular segments of visual surfaces of revolution
_HULL_SEGMENTS = 16  # points per circle of convex collision pieces
_MAX_EDGE = 0.012  # longest profile edge of a visual surface of revolution [m]
_OVERLAP = math.radians(1.5)  # angular overlap of neighbouring wall pieces [rad]


# ---------------------------------------------------------------- specs (parsed from the data)
@dataclass(frozen=True)
class LoopHandle:
    """A half-torus handle on the +x side (mugs, jugs).

    Attributes:
        radius: radius of the loop's centre line [m].
        tube: radius of the handle's cross-section [m].
        z: height of the loop centre [m].
    """

    radius: float
    tube: float
    z: float


@dataclass(frozen=True)
class BarHandle:
    """A straight bar handle along +x (pans).

    Attributes:
        length: length from the wall [m].
        width: width across (y) [m].
        thickness: thickness (z) [m].
        z: height where it leaves the wall [m].
        tilt: upward tilt [rad].
    """

    length: float
    width: float
    thickness: float
    z: float
    tilt: float


@dataclass(frozen=True)
class RevolvedSpec:
    """Surface of revolution (see the module docstring).

    Attributes:
        profile: stations (z, r_outer, r_inner) from the bottom up [m].
        sectors: number of convex wall pieces around the axis.
        handle: optional handle.
    """

    profile: tuple[tuple[float, float, float], ...]
    sectors: int = 12
    handle: LoopHandle | BarHandle | None = None


@dataclass(frozen=True)
class BoxSpec:
    """Closed box. Attributes: size (x, y, z) [m]."""

    size: tuple[float, float, float]


@dataclass(frozen=True)
class TraySpec:
    """Open box with a cavity.

    Attributes:
        size: outer size (x, y, z) [m].
        wall: wall and bottom thickness [m].
        corner_radius: radius of the rounded corners in plan view [m].
    """

    size: tuple[float, float, float]
    wall: float
    corner_radius: float


@dataclass(frozen=True)
class BoardSpec:
    """Rounded slab, optionally with a handle on +x that has a hanging hole.

    Attributes:
        size: slab size (x, y, z) without the handle [m].
        corner_radius: radius of the rounded corners [m].
        handle: (length, width) of the handle, or None [m].
        hole_radius: radius of the hole in the handle (0 for none) [m].
    """

    size: tuple[float, float, float]
    corner_radius: float
    handle: tuple[float, float] | None = None
    hole_radius: float = 0.0


@dataclass(frozen=True)
class CutlerySpec:
    """Fork, spoon or knife lying flat, handle towards -x.

    Attributes:
        style: "fork", "spoon" or "knife".
        length: total length [m].
        handle_length: length of the handle [m].
        handle_width: width of the handle in plan view [m].
        handle_thickness: height of the handle [m].
        head_width: width of the head (tines, bowl, blade) [m].
        head_thickness: height of the head [m].
    """

    style: str
    length: float
    handle_length: float
    handle_width: float
    handle_thickness: float
    head_width: float
    head_thickness: float


@dataclass(frozen=True)
class ScissorsSpec:
    """Closed scissors lying flat, blades towards +x, finger rings towards -x.

    Attributes:
        length: total length [m].
        blade_width: width of the closed blades at the pivot [m].
        ring_radius: outer radius of a finger ring [m].
        ring_width: width of the ring band [m].
        thickness: height of the rings [m].
    """

    length: float
    blade_width: float
    ring_radius: float
    ring_width: float
    thickness: float


@dataclass(frozen=True)
class ImportedSpec:
    """Geometry of an imported mesh, stored in the user registry or the shipped pack.

    Attributes:
        path: the ``geometry.npz`` file holding the normalised mesh and its convex pieces.
        digest: content hash of that file (checked on load).
    """

    path: str
    digest: str


GeometrySpec = RevolvedSpec | BoxSpec | TraySpec | BoardSpec | CutlerySpec | ScissorsSpec | ImportedSpec | MeshSpec


def parse_geometry(f: Field, registry_dir: Path | None = None) -> GeometrySpec:
    """Validate a ``geometry`` object from a class file and return its spec.

    Args:
        f: the field holding the geometry object.
        registry_dir: directory that relative ``imported`` paths and ``mesh`` files are resolved against.

    Raises:
        AssetError: unknown kind, unknown or missing parameter, or an inconsistent value.
    """
    kind = f.mapping(open_keys=True).get("kind")
    if kind is None:
        raise f.child("kind", None).fail(f"missing required key; valid kinds are {', '.join(_PARSERS)}")
    name = kind.choice(_PARSERS)
    if name == "imported":
        return _parse_imported(f, registry_dir)
    if name == "mesh":
        return parse_mesh(f, registry_dir)
    return _PARSERS[name](f)


def _parse_revolved(f: Field) -> RevolvedSpec:
    m = f.mapping(["kind", "profile"], ["sectors", "handle"])
    stations = []
    for s in m["profile"].sequence(2):
        z, ro, ri = s.numbers(3, 0.0, 1.0)
        if ro <= 0:
            raise s.fail(f"r_outer must be > 0, got {ro:g}")
        if ri >= ro:
            raise s.fail(f"r_inner ({ri:g}) must be smaller than r_outer ({ro:g})")
        stations.append((z, ro, ri))
    zs = [s[0] for s in stations]
    if zs[0] != 0.0 or any(b <= a for a, b in zip(zs, zs[1:], strict=False)):
        raise m["profile"].fail("station heights z must start at 0 and strictly increase")
    hollow = [s[2] > 0 for s in stations]
    if hollow[0]:
        raise m["profile"].fail("the first station must be solid (r_inner 0): it is the bottom")
    if any(hollow):
        first = hollow.index(True)
        if not all(hollow[first:]):
            raise m["profile"].fail("hollow stations (r_inner > 0) must form the top run of the profile")
    sectors = 12
    if "sectors" in m:
        sectors = int(m["sectors"].number(6, 64))
    handle: LoopHandle | BarHandle | None = None
    if "handle" in m:
        h = m["handle"]
        kind = h.mapping(open_keys=True).get("type")
        if kind is None:
            raise h.child("type", None).fail("missing required key; valid types are loop, bar")
        if kind.choice(["loop", "bar"]) == "loop":
            hm = h.mapping(["type", "radius", "tube", "z"])
            handle = LoopHandle(hm["radius"].positive(), hm["tube"].positive(), hm["z"].positive())
            if handle.z - handle.radius < 0 or handle.z + handle.radius > zs[-1]:
                raise hm["z"].fail("the loop must fit between the bottom and the top of the profile")
        else:
            hm = h.mapping(["type", "length", "width", "thickness", "z", "tilt"])
            handle = BarHandle(
                hm["length"].positive(),
                hm["width"].positive(),
                hm["thickness"].positive(),
                hm["z"].positive(),
                hm["tilt"].number(-1.0, 1.0),
            )
            if handle.z > zs[-1]:
                raise hm["z"].fail(f"must be at most the profile height {zs[-1]:g}")
    return RevolvedSpec(tuple(stations), sectors, handle)


def _parse_box(f: Field) -> BoxSpec:
    m = f.mapping(["kind", "size"])
    return BoxSpec(_size(m["size"]))


def _parse_tray(f: Field) -> TraySpec:
    m = f.mapping(["kind", "size", "wall", "corner_radius"])
    size = _size(m["size"])
    wall = m["wall"].positive()
    if 2 * wall >= min(size):
        raise m["wall"].fail(f"must be less than half the smallest size {min(size):g}")
    corner = m["corner_radius"].number(0.0, min(size[:2]) / 2)
    return TraySpec(size, wall, corner)


def _parse_board(f: Field) -> BoardSpec:
    m = f.mapping(["kind", "size", "corner_radius"], ["handle", "hole_radius"])
    size = _size(m["size"])
    corner = m["corner_radius"].number(0.0, min(size[:2]) / 2)
    handle = None
    hole = 0.0
    if "handle" in m:
        hl, hw = m["handle"].numbers(2, 0.0)
        if hl <= 0 or hw <= 0 or hw > size[1]:
            raise m["handle"].fail(f"expected [length, width] > 0 with width <= {size[1]:g}")
        handle = (hl, hw)
    if "hole_radius" in m:
        hole = m["hole_radius"].number(0.0)
        if handle is None or 2 * hole >= min(handle):
            raise m["hole_radius"].fail("a hole needs a handle wider and longer than the hole")
    return BoardSpec(size, corner, handle, hole)


def _parse_cutlery(f: Field) -> CutlerySpec:
    keys = ["length", "handle_length", "handle_width", "handle_thickness", "head_width", "head_thickness"]
    m = f.mapping(["kind", "style", *keys])
    style = m["style"].choice(["fork", "spoon", "knife"])
    v = {k: m[k].positive() for k in keys}
    if v["handle_length"] >= 0.85 * v["length"]:
        raise m["handle_length"].fail("must be shorter than 0.85 * length, to leave room for the head")
    return CutlerySpec(style, **v)


def _parse_scissors(f: Field) -> ScissorsSpec:
    keys = ["length", "blade_width", "ring_radius", "ring_width", "thickness"]
    m = f.mapping(["kind", *keys])
    v = {k: m[k].positive() for k in keys}
    if v["ring_width"] >= v["ring_radius"]:
        raise m["ring_width"].fail("must be smaller than ring_radius")
    if 2 * v["ring_radius"] >= 0.6 * v["length"]:
        raise m["ring_radius"].fail("rings too large for the length (2 * ring_radius < 0.6 * length)")
    return ScissorsSpec(**v)


def _parse_imported(f: Field, registry_dir: Path | None) -> ImportedSpec:
    m = f.mapping(["kind", "path", "digest"])
    path = Path(m["path"].string())
    if not path.is_absolute() and registry_dir is not None:
        path = registry_dir / path
    if not path.is_file():
        raise m["path"].fail(f"geometry file {path} does not exist; re-import the mesh")
    return ImportedSpec(str(path), m["digest"].string())


def _size(f: Field) -> tuple[float, float, float]:
    vals = f.numbers(3, 0.0, 2.0)
    if min(vals) <= 0:
        raise f.fail(f"sizes must be > 0 [m], got {list(vals)}")
    return (vals[0], vals[1], vals[2])


_PARSERS = {
    "revolved": _parse_revolved,
    "box": _parse_box,
    "tray": _parse_tray,
    "board": _parse_board,
    "cutlery": _parse_cutlery,
    "scissors": _parse_scissors,
    "imported": _parse_imported,
    "mesh": parse_mesh,
}


# ---------------------------------------------------------------- building
def build_geometry(spec: GeometrySpec, scale: float = 1.0) -> ObjectGeometry:
    """Build (or fetch from the in-memory cache) the geometry for ``spec`` scaled by ``scale``.

    Args:
        spec: parsed geometry parameters at real-world size.
        scale: uniform size factor [-].

    Returns:
        The geometry; shared between callers, treat its arrays as read-only.
    """
    return _build_scaled(spec, float(scale))


@lru_cache(maxsize=512)
def _build_scaled(spec: GeometrySpec, scale: float) -> ObjectGeometry:
    g = _build_base(spec)
    if scale == 1.0:
        return g
    s = scale
    pieces = tuple(
        CollisionPiece(
            p.kind, scale_tuple(p.pos, s), p.quat, scale_tuple(p.half_extents, s), p.vertices * s, p.volume * s**3
        )
        for p in g.pieces
    )
    out = ObjectGeometry(
        vertices=g.vertices * s,
        faces=g.faces,
        texcoords=g.texcoords * s,
        pieces=pieces,
        volume=g.volume * s**3,
        area=g.area * s**2,
        top=g.top.scaled(s),
        opening=g.opening.scaled(s) if g.opening else None,
        grasps=tuple(gs.scaled(s) for gs in g.grasps),
    )
    _freeze(out)
    return out


@lru_cache(maxsize=128)
def _build_base(spec: GeometrySpec) -> ObjectGeometry:
    if isinstance(spec, ImportedSpec):
        g = load_imported_geometry(spec.path, spec.digest)
    elif isinstance(spec, MeshSpec):
        g = load_vendored_geometry(spec)
    else:
        g = _BUILDERS[type(spec)](spec)
    _freeze(g)
    return g


def _freeze(g: ObjectGeometry) -> None:
    for a in (g.vertices, g.faces, g.texcoords, *(p.vertices for p in g.pieces)):
        a.setflags(write=False)


def _finish(
    solid: mf.Manifold,
    pieces: list[CollisionPiece],
    top: TopSurface,
    opening: Opening | None,
    grasps: list[GraspSite],
) -> ObjectGeometry:
    mesh = solid.to_mesh()
    verts = np.asarray(mesh.vert_properties[:, :3], dtype=np.float64)
    faces = np.asarray(mesh.tri_verts, dtype=np.int32)
    return ObjectGeometry(
        vertices=verts,
        faces=faces,
        texcoords=planar_texcoords(verts),
        pieces=tuple(pieces),
        volume=float(solid.volume()),
        area=float(solid.surface_area()),
        top=top,
        opening=opening,
        grasps=tuple(grasps),
    )


def _mesh_piece(points: np.ndarray) -> CollisionPiece:
    pts = np.asarray(points, dtype=np.float64)
    hull = ConvexHull(pts)
    pts = pts[hull.vertices]
    return CollisionPiece("mesh", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), pts, float(hull.volume))


def _box_piece(
    center: tuple[float, float, float],
    half: tuple[float, float, float],
    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0),
) -> CollisionPiece:
    h = tuple(float(x) for x in half)
    return CollisionPiece("box", tuple(float(c) for c in center), quat, h, np.zeros((0, 3)), 8.0 * h[0] * h[1] * h[2])


def _circle(r: float, z: float, n: int = _HULL_SEGMENTS, a0: float = 0.0, a1: float = 2 * math.pi) -> np.ndarray:
    a = np.linspace(a0, a1, n, endpoint=(a1 - a0) < 2 * math.pi - 1e-9)
    return np.stack([r * np.cos(a), r * np.sin(a), np.full_like(a, z)], axis=1)


def _densify(points: list[tuple[float, float]], max_len: float) -> list[tuple[float, float]]:
    """Insert points so that no edge of the closed outline is longer than ``max_len`` [m].

    MuJoCo's classic renderer lights per vertex, so long thin triangles (a fan across a pan's floor)
    show star-shaped highlights; rings of vertices every centimetre avoid that.
    """
    out: list[tuple[float, float]] = []
    n = len(points)
    for i in range(n):
        a, b = np.asarray(points[i]), np.asarray(points[(i + 1) % n])
        k = max(1, math.ceil(float(norm(b - a)) / max_len))
        out += [tuple(a + (b - a) * (j / k)) for j in range(k)]
    return out


def _polygon(points: list[tuple[float, float]]) -> mf.CrossSection:
    pts = np.asarray(points, dtype=np.float64)
    x, y = pts[:, 0], pts[:, 1]
    if 0.5 * float(dot(x, np.roll(y, -1)) - dot(y, np.roll(x, -1))) < 0:
        pts = pts[::-1]
    return mf.CrossSection([pts.tolist()])


def _rounded_rect(sx: float, sy: float, r: float) -> mf.CrossSection:
    r = min(r, 0.5 * min(sx, sy) - 1e-5)
    if r <= 1e-5:
        return mf.CrossSection.square((sx, sy), center=True)
    inner = mf.CrossSection.square((sx - 2 * r, sy - 2 * r), center=True)
    return inner.offset(r, mf.JoinType.Round, circular_segments=32)


def _extrude(cs: mf.CrossSection, height: float, z0: float = 0.0) -> mf.Manifold:
    return mf.Manifold.extrude(cs, height).translate((0.0, 0.0, z0))


def _quat_y(angle: float) -> tuple[float, float, float, float]:
    return (math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0)


# ----- revolved
def _interp_r(profile: tuple[tuple[float, float, float], ...], z: float, inner: bool = False) -> float:
    zs = [p[0] for p in profile]
    rs = [p[2] if inner else p[1] for p in profile]
    return float(np.interp(z, zs, rs))


def _build_revolved(spec: RevolvedSpec) -> ObjectGeometry:
    prof = spec.profile
    hollow = [i for i, p in enumerate(prof) if p[2] > 0]
    z_top = prof[-1][0]
    outline: list[tuple[float, float]] = [(0.0, 0.0)] + [(ro, z) for z, ro, _ in prof]
    if hollow:
        outline += [(ri, z) for z, _, ri in reversed(prof[hollow[0] :])]
        outline.append((0.0, prof[hollow[0]][0]))
    else:
        outline.append((0.0, z_top))
    solid = mf.Manifold.revolve(_polygon(_densify(outline, _MAX_EDGE)), _SEGMENTS)

    pieces: list[CollisionPiece] = []
    solid_end = hollow[0] if hollow else len(prof) - 1
    for a, b in zip(prof[:solid_end], prof[1 : solid_end + 1], strict=False):
        pieces.append(_mesh_piece(np.vstack([_circle(a[1], a[0]), _circle(b[1], b[0])])))
    if hollow:
        n = spec.sectors
        step = 2 * math.pi / n
        for a, b in zip(prof[hollow[0] : -1], prof[hollow[0] + 1 :], strict=False):
            for j in range(n):
                a0, a1 = j * step - _OVERLAP, (j + 1) * step + _OVERLAP
                pts = [
                    _circle(r, z, 2, a0, a1 + 1e-12)
                    for z, r in ((a[0], a[1]), (a[0], a[2]), (b[0], b[1]), (b[0], b[2]))
                ]
                pieces.append(_mesh_piece(np.vstack(pts)))

    grasps: list[GraspSite] = []
    if spec.handle is not None:
        solid, handle_pieces, site = _add_handle(solid, spec)
        pieces += handle_pieces
        grasps.append(site)

    if hollow:
        floor_z, floor_r = prof[hollow[0]][0], prof[hollow[0]][2]
        rim_r_out, rim_r_in = prof[-1][1], prof[-1][2]
        opening = Opening(radius=min(p[2] for p in prof[hollow[0] :]), floor_height=floor_z, depth=z_top - floor_z)
        top = TopSurface(floor_z, (0.0, 0.0), (floor_r, floor_r), True, floor_r >= 0.01)
        wall = rim_r_out - rim_r_in
        rim = GraspSite(
            "rim",
            (0.5 * (rim_r_out + rim_r_in), 0.0, z_top - min(0.015, 0.3 * (z_top - floor_z))),
            (0.0, 0.0, -1.0),
            (1.0, 0.0, 0.0),
            wall,
            axisymmetric=True,
        )
        body_w = 2 * prof[-1][1]
        body = GraspSite("body", (0.0, 0.0, 0.6 * z_top), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), body_w, True)
        # A narrow open shape is best held around its body; a wide one by its rim.
        grasps += [body, rim] if body_w <= GRIPPER_STROKE else [rim, body]
    else:
        opening = None
        r_top = prof[-1][1]
        top = TopSurface(z_top, (0.0, 0.0), (r_top, r_top), True, r_top >= 0.01)
        z_grip = max(0.5 * z_top, z_top - 0.03)
        grasps.append(
            GraspSite("body", (0.0, 0.0, z_grip), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), 2 * _interp_r(prof, z_grip), True)
        )
    if isinstance(spec.handle, LoopHandle | BarHandle):
        grasps.sort(key=lambda g: g.name != "handle")
    return _finish(solid, pieces, top, opening, grasps)


def _add_handle(solid: mf.Manifold, spec: RevolvedSpec) -> tuple[mf.Manifold, list[CollisionPiece], GraspSite]:
    prof = spec.profile
    h = spec.handle
    pieces: list[CollisionPiece] = []
    if isinstance(h, LoopHandle):
        r_attach = min(_interp_r(prof, h.z - h.radius), _interp_r(prof, h.z + h.radius))
        xc = r_attach - 0.6 * h.tube
        ring = mf.Manifold.revolve(mf.CrossSection.circle(h.tube, 24).translate((h.radius, 0.0)), _SEGMENTS, 180.0)
        ring = ring.rotate((0.0, 0.0, -90.0)).rotate((90.0, 0.0, 0.0)).translate((xc, 0.0, h.z))
        solid = solid + ring
        n_arc = 6
        angles = np.linspace(-math.pi / 2, math.pi / 2, n_arc + 1)
        for a0, a1 in zip(angles[:-1], angles[1:], strict=False):
            pts = []
            for a in (a0, a1):
                cx, cz = xc + h.radius * math.cos(a), h.z + h.radius * math.sin(a)
                # tube cross-section: circle in the plane spanned by the radial direction and y
                radial = np.array([math.cos(a), 0.0, math.sin(a)])
                for t in np.linspace(0, 2 * math.pi, 8, endpoint=False):
                    off = h.tube * (math.cos(t) * radial + math.sin(t) * np.array([0.0, 1.0, 0.0]))
                    pts.append(np.array([cx, 0.0, cz]) + off)
            pieces.append(_mesh_piece(np.array(pts)))
        site = GraspSite("handle", (xc + h.radius, 0.0, h.z), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), 2 * h.tube)
    else:
        assert isinstance(h, BarHandle)
        r_attach = _interp_r(prof, h.z)
        x0 = r_attach - 0.01
        bar = mf.Manifold.cube((h.length + 0.01, h.width, h.thickness)).translate((0.0, -h.width / 2, -h.thickness / 2))
        bar = bar.rotate((0.0, -math.degrees(h.tilt), 0.0)).translate((x0, 0.0, h.z))
        solid = solid + bar
        half = ((h.length + 0.01) / 2, h.width / 2, h.thickness / 2)
        c = (x0 + half[0] * math.cos(h.tilt), 0.0, h.z + half[0] * math.sin(h.tilt))
        pieces.append(_box_piece(c, half, _quat_y(-h.tilt)))
        grip = 0.65
        site = GraspSite(
            "handle",
            (x0 + grip * h.length * math.cos(h.tilt), 0.0, h.z + grip * h.length * math.sin(h.tilt)),
            (0.0, 0.0, -1.0),
            (0.0, 1.0, 0.0),
            h.width,
        )
    hollow = [i for i, p in enumerate(prof) if p[2] > 0]
    if hollow:
        # The handle's ends must not stick into the cavity.
        inner = [(0.0, prof[hollow[0]][0])] + [(ri, z) for z, _, ri in prof[hollow[0] :]]
        top = prof[-1][0] + 0.05
        inner += [(prof[-1][2], top), (0.0, top)]
        solid = solid - mf.Manifold.revolve(_polygon(inner), _SEGMENTS)
    return solid, pieces, site


# ----- boxes, trays, boards
def _build_box(spec: BoxSpec) -> ObjectGeometry:
    sx, sy, sz = spec.size
    solid = _extrude(_rounded_rect(sx, sy, 0.003), sz)
    pieces = [_box_piece((0.0, 0.0, sz / 2), (sx / 2, sy / 2, sz / 2))]
    top = TopSurface(sz, (0.0, 0.0), (sx / 2, sy / 2), False, True)
    return _finish(solid, pieces, top, None, _box_grasps(sx, sy, sz))


def _box_grasps(sx: float, sy: float, sz: float) -> list[GraspSite]:
    z = max(sz / 2, sz - 0.03)
    across_y = GraspSite("body", (0.0, 0.0, z), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), sy)
    across_x = GraspSite("body", (0.0, 0.0, z), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0), sx)
    return [across_y, across_x] if sy <= sx else [across_x, across_y]


def _build_tray(spec: TraySpec) -> ObjectGeometry:
    sx, sy, sz = spec.size
    w = spec.wall
    outer = _extrude(_rounded_rect(sx, sy, spec.corner_radius), sz)
    cavity = _extrude(_rounded_rect(sx - 2 * w, sy - 2 * w, max(spec.corner_radius - w, 0.0)), sz, w)
    solid = outer - cavity
    pieces = [
        _box_piece((0.0, 0.0, w / 2), (sx / 2, sy / 2, w / 2)),
        _box_piece(((sx - w) / 2, 0.0, sz / 2), (w / 2, sy / 2, sz / 2)),
        _box_piece((-(sx - w) / 2, 0.0, sz / 2), (w / 2, sy / 2, sz / 2)),
        _box_piece((0.0, (sy - w) / 2, sz / 2), (sx / 2, w / 2, sz / 2)),
        _box_piece((0.0, -(sy - w) / 2, sz / 2), (sx / 2, w / 2, sz / 2)),
    ]
    inner = ((sx - 2 * w) / 2, (sy - 2 * w) / 2)
    top = TopSurface(w, (0.0, 0.0), inner, False, True)
    opening = Opening(min(inner), w, sz - w)
    rim_z = sz - min(0.01, sz / 3)
    grasps = [
        GraspSite("rim", ((sx - w) / 2, 0.0, rim_z), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0), w),
        GraspSite("rim", (0.0, (sy - w) / 2, rim_z), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), w),
    ]
    return _finish(solid, pieces, top, opening, grasps)


def _build_board(spec: BoardSpec) -> ObjectGeometry:
    sx, sy, sz = spec.size
    cs = _rounded_rect(sx, sy, spec.corner_radius)
    pieces = [_box_piece((0.0, 0.0, sz / 2), (sx / 2, sy / 2, sz / 2))]
    grasps: list[GraspSite] = []
    if spec.handle is not None:
        hl, hw = spec.handle
        handle = _rounded_rect(hl + 0.02, hw, min(hw / 2 - 1e-4, 0.02)).translate((sx / 2 + (hl + 0.02) / 2 - 0.02, 0))
        cs = cs + handle
        if spec.hole_radius > 0:
            cs = cs - mf.CrossSection.circle(spec.hole_radius, 32).translate((sx / 2 + hl / 2 + 0.005, 0.0))
        pieces.append(_box_piece((sx / 2 + hl / 2 - 0.005, 0.0, sz / 2), (hl / 2 + 0.005, hw / 2, sz / 2)))
        grasps.append(GraspSite("handle", (sx / 2 + hl / 2, 0.0, sz / 2), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), hw))
    solid = _extrude(cs, sz)
    # Lying flat, a board is held by its edge from the side (the planner must check clearance).
    grasps.append(GraspSite("edge", (-sx / 2, 0.0, sz / 2), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), sz))
    top = TopSurface(sz, (0.0, 0.0), (sx / 2 - 0.01, sy / 2 - 0.01), False, True)
    return _finish(solid, pieces, top, None, grasps)


# ----- cutlery and scissors
def _build_cutlery(spec: CutlerySpec) -> ObjectGeometry:
    L, hl, hw, ht = spec.length, spec.handle_length, spec.handle_width, spec.handle_thickness
    w, t = spec.head_width, spec.head_thickness
    x0 = -L / 2
    x_handle_end = x0 + hl
    handle_cs = _rounded_rect(hl, hw, hw * 0.45).translate((x0 + hl / 2, 0.0))
    handle = _extrude(handle_cs, ht)
    pieces = [_box_piece((x0 + hl / 2, 0.0, ht / 2), (hl / 2, hw / 2, ht / 2))]
    head_len = L - hl
    if spec.style == "knife":
        spine = hw / 2
        edge = spine - w
        tip_x = L / 2
        pts = [(x_handle_end - 0.005, spine), (x_handle_end - 0.005, edge)]
        for k in range(1, 9):  # the edge curves up to the tip
            u = k / 8
            pts.append((x_handle_end + u * head_len, edge + (spine - 0.15 * w - edge) * u**3))
        pts += [(tip_x, spine - 0.15 * w), (tip_x - 0.15 * head_len, spine)]
        head_cs = _polygon(pts)
        pieces.append(_box_piece((x_handle_end + head_len / 2, spine - w / 2, t / 2), (head_len / 2, w / 2, t / 2)))
    else:
        neck = 0.35 * head_len
        nx0 = x_handle_end - 0.004
        nx1 = x_handle_end + neck
        head_x0 = nx1 - 0.002
        if spec.style == "spoon":
            bowl_len = L / 2 - head_x0
            neck_cs = _polygon([(nx0, 0.3 * hw), (nx0, -0.3 * hw), (nx1 + 0.005, -0.1 * w), (nx1 + 0.005, 0.1 * w)])
            bowl_cs = (
                mf.CrossSection.circle(1.0, 48).scale((bowl_len / 2, w / 2)).translate((head_x0 + bowl_len / 2, 0.0))
            )
            head_cs = neck_cs + bowl_cs
            pieces.append(_box_piece((head_x0 + bowl_len / 2, 0.0, t / 2), (bowl_len / 2, w / 2 * 0.8, t / 2)))
        else:  # fork
            fork_len = L / 2 - head_x0
            neck_cs = _polygon([(nx0, 0.3 * hw), (nx0, -0.3 * hw), (nx1 + 0.003, -0.45 * w), (nx1 + 0.003, 0.45 * w)])
            body = _rounded_rect(fork_len, w, 0.004).translate((head_x0 + fork_len / 2, 0.0))
            slot_len = 0.6 * fork_len
            slot_w = w / 9
            for k in (-1, 0, 1):
                slot = mf.CrossSection.square((slot_len + 0.01, slot_w), center=True).translate(
                    (L / 2 - slot_len / 2 + 0.005, k * 2 * w / 7)
                )
                body = body - slot
            head_cs = neck_cs + body
            pieces.append(_box_piece((head_x0 + fork_len / 2, 0.0, t / 2), (fork_len / 2, w / 2, t / 2)))
        pieces.append(_box_piece(((nx0 + nx1) / 2, 0.0, t / 2), ((nx1 - nx0) / 2, 0.25 * hw, t / 2)))
    solid = handle + _extrude(head_cs, t)
    grasps = [GraspSite("handle", (x0 + 0.55 * hl, 0.0, ht / 2), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), hw)]
    top = TopSurface(ht, (x0 + hl / 2, 0.0), (hl / 2, hw / 2), False, False)
    return _finish(solid, pieces, top, None, grasps)


def _build_scissors(spec: ScissorsSpec) -> ObjectGeometry:
    L, bw, rr, rw, t = spec.length, spec.blade_width, spec.ring_radius, spec.ring_width, spec.thickness
    x_pivot = -L / 2 + 2 * rr + 0.25 * L - rr
    x_tip = L / 2
    bt = 0.45 * t  # blades are thinner than the rings
    blades = _polygon(
        [
            (x_pivot - 0.01, bw / 2),
            (x_pivot - 0.01, -bw / 2),
            (x_tip - 0.01, -0.08 * bw),
            (x_tip, 0.02 * bw),
            (x_tip - 0.02, 0.12 * bw),
        ]
    )
    pivot = mf.CrossSection.circle(0.55 * bw, 32).translate((x_pivot, 0.0))
    rings = mf.CrossSection()
    ring_pieces = []
    for side in (-1.0, 1.0):
        cx, cy = -L / 2 + rr, side * 0.95 * rr
        ring = mf.CrossSection.circle(rr, 40) - mf.CrossSection.circle(rr - rw, 40)
        rings = rings + ring.translate((cx, cy))
        arm = _polygon(
            [
                (cx + 0.7 * rr, cy),
                (cx + 0.7 * rr, cy + side * -0.8 * rw),
                (x_pivot, side * 0.1 * bw),
                (x_pivot, side * 0.45 * bw),
            ]
        )
        rings = rings + arm
        ring_pieces.append(_box_piece((cx, cy, t / 2), (rr, rr, t / 2)))
    solid = _extrude(rings, t) + _extrude(blades + pivot, bt)
    blade_len = x_tip - x_pivot
    pieces = [
        _box_piece(((x_pivot + x_tip) / 2, 0.0, bt / 2), (blade_len / 2, bw / 2, bt / 2)),
        _box_piece(
            ((-L / 2 + 2 * rr + x_pivot) / 2, 0.0, t / 2), ((x_pivot - (-L / 2 + 2 * rr)) / 2 + 0.005, 0.5 * bw, t / 2)
        ),
        *ring_pieces,
    ]
    grasps = [
        GraspSite("body", (x_pivot, 0.0, bt / 2), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), 1.1 * bw),
        GraspSite("handle", (-L / 2 + rr, 0.0, t / 2), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), 2 * 0.95 * rr + 2 * rr),
    ]
    top = TopSurface(t, (-L / 2 + rr, 0.0), (rr, 2 * rr), False, False)
    return _finish(solid, pieces, top, None, grasps)


_BUILDERS = {
    RevolvedSpec: _build_revolved,
    BoxSpec: _build_box,
    TraySpec: _build_tray,
    BoardSpec: _build_board,
    CutlerySpec: _build_cutlery,
    ScissorsSpec: _build_scissors,
}
