"""Geometry results shared by procedural and imported objects: collision pieces, grasp sites, top
surfaces, openings and the :class:`ObjectGeometry` that holds them (no mesh building here)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull

__all__ = [
    "read_mesh_arrays",
    "CollisionPiece",
    "convex_pieces",
    "GraspSite",
    "ObjectGeometry",
    "Opening",
    "TopSurface",
    "mesh_area",
    "planar_texcoords",
    "scale_tuple",
]


@dataclass(frozen=True, eq=False)
class CollisionPiece:
    """One convex collision shape in the object frame.

    Attributes:
        kind: "box" or "mesh".
        pos: box centre [m] (meshes: zeros, vertices are in the object frame).
        quat: box orientation (w, x, y, z).
        half_extents: box half sizes [m].
        vertices: (n, 3) convex mesh points [m] (boxes: empty).
        volume: volume of the piece [m^3].
    """

    kind: str
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float]
    half_extents: tuple[float, float, float]
    vertices: np.ndarray
    volume: float


@dataclass(frozen=True)
class GraspSite:
    """Where the gripper can hold an object (a hint for the grasp planner).

    Attributes:
        name: "body", "rim", "handle" or "edge".
        position: grasp centre in the object frame [m].
        approach: unit vector along which the gripper moves in to grasp (object frame).
        closing: unit vector along which the fingers close (object frame).
        width: extent of the object between the fingers [m].
        axisymmetric: the site may be rotated freely about the object's z axis.
    """

    name: str
    position: tuple[float, float, float]
    approach: tuple[float, float, float]
    closing: tuple[float, float, float]
    width: float
    axisymmetric: bool = False

    def scaled(self, s: float) -> GraspSite:
        """Return the site for the object scaled by ``s``."""
        return GraspSite(
            self.name, scale_tuple(self.position, s), self.approach, self.closing, self.width * s, self.axisymmetric
        )


@dataclass(frozen=True)
class TopSurface:
    """The surface another object placed on this one rests on.

    Attributes:
        height: z of the surface [m].
        center: (x, y) of its centre [m].
        half_extents: (x, y) half sizes of the usable area; equal for round surfaces [m].
        round: the area is a disc of radius half_extents[0].
        flat: the surface is flat and large enough (>= 2 cm across) to support another object.
    """

    height: float
    center: tuple[float, float]
    half_extents: tuple[float, float]
    round: bool
    flat: bool

    def scaled(self, s: float) -> TopSurface:
        """Return the surface of the object scaled by ``s``."""
        return TopSurface(
            self.height * s, scale_tuple(self.center, s), scale_tuple(self.half_extents, s), self.round, self.flat
        )


@dataclass(frozen=True)
class Opening:
    """The inside of a container.

    Attributes:
        radius: radius of the largest disc that passes through the opening [m].
        floor_height: z of the inner floor [m].
        depth: from the inner floor to the rim [m].
        center: (x, y) of the opening [m].
    """

    radius: float
    floor_height: float
    depth: float
    center: tuple[float, float] = (0.0, 0.0)

    def scaled(self, s: float) -> Opening:
        """Return the opening of the object scaled by ``s``."""
        return Opening(self.radius * s, self.floor_height * s, self.depth * s, scale_tuple(self.center, s))


@dataclass(frozen=True, eq=False)
class ObjectGeometry:
    """Geometry of one (class, variant, size): meshes, collision pieces and shape facts.

    Attributes:
        vertices: (n, 3) visual mesh vertices [m].
        faces: (m, 3) visual mesh triangles (counter-clockwise seen from outside).
        texcoords: (n, 2) texture coordinates per vertex (planar wood-grain mapping).
        pieces: convex collision pieces.
        volume: volume of the modelled material (the visual mesh) [m^3].
        area: surface area of the visual mesh [m^2].
        top: surface that supports an object placed on this one.
        opening: inside of the container, if the shape is open at the top.
        grasps: grasp sites, best first.
    """

    vertices: np.ndarray
    faces: np.ndarray
    texcoords: np.ndarray
    pieces: tuple[CollisionPiece, ...]
    volume: float
    area: float
    top: TopSurface
    opening: Opening | None
    grasps: tuple[GraspSite, ...]

    @property
    def pieces_volume(self) -> float:
        """Total volume of the collision pieces [m^3]."""
        return float(sum(p.volume for p in self.pieces))


def scale_tuple(t: tuple[float, ...], s: float) -> tuple[float, ...]:
    return tuple(float(v) * s for v in t)


# ---------------------------------------------------------------- parsing


def planar_texcoords(vertices: np.ndarray, repeat: float = 0.3) -> np.ndarray:
    """Texture coordinates for wood grain: grain runs along x, rings vary with y and z.

    Args:
        vertices: (n, 3) points [m].
        repeat: length covered by one copy of the texture [m].
    """
    v = np.asarray(vertices, dtype=np.float64)
    return np.stack([v[:, 0] / repeat, (v[:, 1] + 0.6 * v[:, 2]) / repeat], axis=1)


def read_mesh_arrays(path: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A mesh file of plain arrays (read with ``allow_pickle=False``): vertices (V, 3), faces (F, 3),
    and the convex pieces as point counts (P,) and their points stacked (sum of counts, 3).

    Raises:
        OSError, ValueError, KeyError: unreadable, not plain arrays, or an array missing.
    """
    with np.load(path, allow_pickle=False) as z:
        return (np.asarray(z["vertices"], np.float64), np.asarray(z["faces"], np.int32),
                np.asarray(z["piece_counts"], np.int64), np.asarray(z["piece_points"], np.float64))


def convex_pieces(counts: np.ndarray, points: np.ndarray) -> tuple[CollisionPiece, ...]:
    """The convex collision pieces stored as point counts (P,) and their points stacked (sum, 3) [m]:
    each piece is the convex hull of its points (numpy and scipy only, no mesh library)."""
    pieces = []
    for pts in np.split(points, np.cumsum(counts)[:-1]):
        hull = ConvexHull(pts)
        pieces.append(CollisionPiece("mesh", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                                     np.ascontiguousarray(pts[hull.vertices]), float(hull.volume)))
    return tuple(pieces)


def mesh_area(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Surface area of a triangle mesh [m^2]."""
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return 0.5 * float(np.sqrt((cross * cross).sum(axis=1)).sum())
