"""Per-instance geometry facts for scene sampling, stacking, containers and grasp planning.

All lengths are in the object frame (z up, the object rests on z = 0, handles towards +x) and
include the instance's size factor. Transform them with the body pose to get world values.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from functools import lru_cache

import numpy as np
from scipy.spatial import ConvexHull

from samplehd.catalogue.geometry import (
    GRIPPER_STROKE,
    GraspSite,
    ObjectGeometry,
    Opening,
    TopSurface,
    build_geometry,
)
from samplehd.catalogue.instance import ObjectInstance
from samplehd.catalogue.loader import resolve_catalogue
from samplehd.catalogue.model import Affordances, Catalogue, MassModel, Material
from samplehd.fixedmath import matmul

__all__ = ["ObjectFacts", "instance_geometry", "mass_of", "object_facts"]


@dataclass(frozen=True)
class ObjectFacts:
    """What later stages need to know about one object instance.

    Attributes:
        instance: the instance described.
        bbox_min: lower corner of the axis-aligned bounding box in the object frame [m].
        bbox_max: upper corner of the bounding box [m].
        extents: bbox_max - bbox_min, full sizes along x, y, z [m].
        height: height above its resting plane [m] (= extents[2]).
        footprint_center: (x, y) centre of the bounding rectangle in the object frame [m].
        footprint_half_extents: (x, y) half sizes of the bounding rectangle around footprint_center [m].
        footprint_polygon: convex hull of the object seen from above, counter-clockwise (x, y) [m].
        footprint_radius: largest distance of the footprint from the object origin [m]
            (a circle of this radius around the origin contains the object at any yaw).
        top: surface an object placed on this one rests on (flat=False: nothing can be placed).
        opening: inside of the container, or None (also None when the class is not a container).
        grasps: grasp sites, best first, each with its width between the fingers.
        graspable_sites: grasp sites whose width fits the gripper's stroke (85 mm).
        mass: mass [kg].
        weight: weight class name (light, medium, heavy).
        volume: modelled material volume of the visual mesh [m^3].
        affordances: graspable, handle_pickable, container, stackable_on, stackable.
        friction: MuJoCo friction of the material (sliding, torsional, rolling).
        num_collision_pieces: number of convex collision geoms.
    """

    instance: ObjectInstance
    bbox_min: tuple[float, float, float]
    bbox_max: tuple[float, float, float]
    extents: tuple[float, float, float]
    height: float
    footprint_center: tuple[float, float]
    footprint_half_extents: tuple[float, float]
    footprint_polygon: tuple[tuple[float, float], ...]
    footprint_radius: float
    top: TopSurface
    opening: Opening | None
    grasps: tuple[GraspSite, ...]
    graspable_sites: tuple[GraspSite, ...]
    mass: float
    weight: str
    volume: float
    affordances: Affordances
    friction: tuple[float, float, float]
    num_collision_pieces: int

    @property
    def top_extent(self) -> tuple[float, float] | None:
        """Full sizes (x, y) of the flat top things can stand on [m], or None (instructions' ``top_extent``)."""
        if not self.top.flat:
            return None
        hx, hy = self.top.half_extents
        return (2 * hx, 2 * hy)

    @property
    def opening_radius(self) -> float | None:
        """Radius of a container's opening [m], or None (instructions' ``opening_radius``)."""
        return float(self.opening.radius) if self.opening else None

    def footprint_at(self, x: float, y: float, yaw: float) -> np.ndarray:
        """The footprint polygon of the object placed at (x, y) with a rotation ``yaw`` about z.

        Args:
            x: world x of the object origin [m].
            y: world y of the object origin [m].
            yaw: rotation about the world z axis [rad].

        Returns:
            (n, 2) counter-clockwise polygon in world x, y [m].
        """
        c, s = np.cos(yaw), np.sin(yaw)
        poly = np.asarray(self.footprint_polygon, dtype=np.float64)
        return matmul(poly, np.array([[c, s], [-s, c]])) + np.array([x, y])

    def to_dict(self) -> dict:
        """Return the facts as a JSON-ready dict (tuples become lists)."""
        d = asdict(self)
        d["instance"] = self.instance.to_dict()
        return _lists(d)


def _lists(v):  # noqa: ANN001, ANN202 - recursive JSON conversion
    if isinstance(v, dict):
        return {k: _lists(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_lists(x) for x in v]
    return v


def instance_geometry(instance: ObjectInstance, catalogue: Catalogue | None = None) -> ObjectGeometry:
    """Return the (cached) geometry of an instance: its variant's shape at its size.

    Args:
        instance: the object.
        catalogue: catalogue to look it up in (default: built-in plus the instance's class if imported).
    """
    cat = resolve_catalogue(catalogue, (instance.class_name,), instance.variant)
    variant = cat.object_class(instance.class_name).variant(instance.variant)
    return build_geometry(variant.geometry, cat.size(instance.size).scale)


def mass_of(geometry: ObjectGeometry, material: Material, model: MassModel) -> float:
    """Mass of an object [kg] from its geometry, material density and mass model.

    Args:
        geometry: geometry at the instance's size.
        material: material (density [kg/m^3], sheet factor).
        model: thin-walled/shell/contents description of the class.
    """
    volume = geometry.area * model.shell if model.shell is not None else geometry.volume
    mass = material.density * volume * (material.sheet_factor if model.thin_walled else 1.0)
    if model.contents_density > 0:
        enclosed = geometry.volume if model.shell is not None else 0.0
        mass += model.contents_density * model.fill * enclosed
    return float(mass)


def object_facts(instance: ObjectInstance, catalogue: Catalogue | None = None) -> ObjectFacts:
    """Compute the geometry facts of an instance (cached per instance).

    Args:
        instance: the object.
        catalogue: catalogue to look it up in (default: built-in plus the instance's class if imported).

    Raises:
        AssetError: the instance names something the catalogue does not know.
    """
    cat = resolve_catalogue(catalogue, (instance.class_name,), instance.variant)
    return _facts(instance, cat)


@lru_cache(maxsize=1024)
def _facts(instance: ObjectInstance, cat: Catalogue) -> ObjectFacts:
    instance.validate(cat)
    cls = cat.object_class(instance.class_name)
    variant = cls.variant(instance.variant)
    material = cat.material(instance.material)
    g = build_geometry(variant.geometry, cat.size(instance.size).scale)
    v = g.vertices
    lo, hi = v.min(axis=0), v.max(axis=0)
    xy = v[:, :2]
    hull = ConvexHull(xy)
    poly = tuple((float(xy[i, 0]), float(xy[i, 1])) for i in hull.vertices)  # counter-clockwise
    mass = mass_of(g, material, cls.mass)
    grasps = g.grasps
    return ObjectFacts(
        instance=instance,
        bbox_min=(float(lo[0]), float(lo[1]), float(lo[2])),
        bbox_max=(float(hi[0]), float(hi[1]), float(hi[2])),
        extents=(float(hi[0] - lo[0]), float(hi[1] - lo[1]), float(hi[2] - lo[2])),
        height=float(hi[2] - lo[2]),
        footprint_center=(float(lo[0] + hi[0]) / 2, float(lo[1] + hi[1]) / 2),
        footprint_half_extents=(float(hi[0] - lo[0]) / 2, float(hi[1] - lo[1]) / 2),
        footprint_polygon=poly,
        footprint_radius=float(np.max(np.linalg.norm(xy, axis=1))),
        top=g.top,
        opening=g.opening if variant.affordances.container else None,
        grasps=grasps,
        graspable_sites=tuple(s for s in grasps if s.width <= GRIPPER_STROKE),
        mass=mass,
        weight=cat.weight_class(mass),
        volume=g.volume,
        affordances=variant.affordances,
        friction=material.friction,
        num_collision_pieces=len(g.pieces),
    )
