"""Object catalogue: classes, variants, colours, materials, sizes, asset menus and geometry.

Typical use::

    import samplehd
    import mujoco
    from samplehd.catalogue import ObjectInstance, add_object, object_facts

    mug = ObjectInstance("mug", "tapered", "red", "ceramic", "medium")
    spec = mujoco.MjSpec()
    add_object(spec, mug, "object_0", pos=(0.0, 0.0, 0.0))
    model = spec.compile()
    facts = object_facts(mug)   # extents, footprint, top surface, opening, grasps, mass, weight

Mesh import lives in :mod:`samplehd.catalogue.importer` (``import_mesh``), previews in
:mod:`samplehd.catalogue.preview`; both pull in heavier dependencies and are not imported here.
"""

from __future__ import annotations

from samplehd.catalogue.builder import COLLISION_GROUP, VISUAL_GROUP, add_object, material_rgba
from samplehd.catalogue.facts import ObjectFacts, instance_geometry, mass_of, object_facts
from samplehd.catalogue.geometry import (
    GRIPPER_STROKE,
    CollisionPiece,
    GraspSite,
    ObjectGeometry,
    Opening,
    TopSurface,
    build_geometry,
)
from samplehd.catalogue.instance import ObjectInstance
from samplehd.catalogue.loader import catalogue_for, load_catalogue, read_catalogue
from samplehd.catalogue.menu import apply_menu_overrides, validate_menu_overrides
from samplehd.catalogue.model import (
    PROPERTIES,
    Affordances,
    AssetMenu,
    Catalogue,
    Colour,
    MassModel,
    Material,
    ObjectClass,
    SizeClass,
    Variant,
    WeightClass,
)

__all__ = [
    "COLLISION_GROUP",
    "GRIPPER_STROKE",
    "PROPERTIES",
    "VISUAL_GROUP",
    "Affordances",
    "AssetMenu",
    "Catalogue",
    "CollisionPiece",
    "Colour",
    "GraspSite",
    "MassModel",
    "Material",
    "ObjectClass",
    "ObjectFacts",
    "ObjectGeometry",
    "ObjectInstance",
    "Opening",
    "SizeClass",
    "TopSurface",
    "Variant",
    "WeightClass",
    "add_object",
    "apply_menu_overrides",
    "build_geometry",
    "catalogue_for",
    "instance_geometry",
    "load_catalogue",
    "mass_of",
    "material_rgba",
    "object_facts",
    "read_catalogue",
    "validate_menu_overrides",
]
