"""Value types of the object catalogue: colours, materials, sizes, weights, classes and menus.

All are frozen dataclasses built by :mod:`samplehd.catalogue.loader` from the JSON data files in
``samplehd/catalogue/data`` (and from imported classes in the user registry).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypedDict

from samplehd.errors import AssetError

if TYPE_CHECKING:
    from samplehd.catalogue.geometry import GeometrySpec

__all__ = [
    "PROPERTIES",
    "Affordances",
    "AssetMenu",
    "Catalogue",
    "CatalogueRecord",
    "Colour",
    "MassModel",
    "Material",
    "ObjectClass",
    "SizeClass",
    "Variant",
    "WeightClass",
]


class CatalogueRecord(TypedDict, total=False):
    """What a catalogue was read from (:meth:`Catalogue.record`), as outputs record it: the built-in
    catalogue's name, the hash of all below, the built-in data files' hash and, per imported class held,
    its registry files' hash. Records older than catalogue names lack ``name``."""

    name: str
    sha256: str
    built_in: str
    imported: dict[str, str]

# The three properties an asset menu can randomise, in the order they are drawn.
PROPERTIES = ("colour", "material", "size")


@dataclass(frozen=True)
class Colour:
    """A named colour.

    Attributes:
        name: colour name (one of the SAMPLE-HD colours or a user one).
        rgba: red, green, blue, alpha, each in [0, 1].
        materials: materials this colour can appear with; empty means any.
    """

    name: str
    rgba: tuple[float, float, float, float]
    materials: tuple[str, ...] = ()


@dataclass(frozen=True)
class Material:
    """A material: how it looks and how it behaves.

    Attributes:
        name: material name.
        specular: MuJoCo material specular in [0, 1].
        shininess: MuJoCo material shininess in [0, 1].
        reflectance: MuJoCo material reflectance in [0, 1].
        alpha: opacity multiplier applied to the colour's alpha in [0, 1] (glass < 1).
        texture: name of a procedural texture ("wood_grain") or None.
        density: density of the solid material [kg/m^3].
        friction: MuJoCo friction (sliding, torsional, rolling) [-, m, m].
        sheet_factor: for thin-walled objects, wall thickness of this material relative to
            the modelled wall (metal sheet is thinner than ceramic); multiplies the mass only [-].
        colours: colours this material can take; empty means any.
    """

    name: str
    specular: float
    shininess: float
    reflectance: float
    alpha: float
    texture: str | None
    density: float
    friction: tuple[float, float, float]
    sheet_factor: float
    colours: tuple[str, ...] = ()


@dataclass(frozen=True)
class SizeClass:
    """A size class and its uniform scale factor relative to the real-world ("medium") dimensions.

    Attributes:
        name: small, medium or large.
        scale: scale factor applied to every dimension [-].
    """

    name: str
    scale: float


@dataclass(frozen=True)
class WeightClass:
    """A weight class: objects with mass below ``max_mass`` (and above the previous class).

    Attributes:
        name: light, medium or heavy.
        max_mass: upper bound (exclusive) [kg]; None for the heaviest class.
    """

    name: str
    max_mass: float | None


@dataclass(frozen=True)
class Affordances:
    """What the robot and the task families may do with an object.

    Attributes:
        graspable: can be picked up by the parallel gripper.
        handle_pickable: has a handle that can be grasped.
        container: other objects can be put into it.
        stackable_on: other objects can be placed on top of it.
        stackable: it can be placed on top of another object.
    """

    graspable: bool
    handle_pickable: bool
    container: bool
    stackable_on: bool
    stackable: bool

    def to_dict(self) -> dict[str, bool]:
        """Return the flags as a JSON-ready dict."""
        return {
            "graspable": self.graspable,
            "handle_pickable": self.handle_pickable,
            "container": self.container,
            "stackable_on": self.stackable_on,
            "stackable": self.stackable,
        }


@dataclass(frozen=True)
class MassModel:
    """How the mass of an object follows from its geometry and material.

    mass = density * V * (sheet_factor if thin_walled) + contents_density * fill * enclosed volume, where
    V is the modelled material volume, or the surface area times ``shell`` for closed shapes.

    Attributes:
        thin_walled: modelled thicker than the real object (walls, sheet, cutlery); the
            material's sheet_factor scales the mass.
        shell: wall thickness of a closed shape modelled as solid [m]; None uses the mesh volume.
        contents_density: density of what fills a closed shape (drink, cereal) [kg/m^3].
        fill: fraction of the enclosed volume filled with contents [-].
    """

    thin_walled: bool = False
    shell: float | None = None
    contents_density: float = 0.0
    fill: float = 1.0


@dataclass(frozen=True)
class AssetMenu:
    """The SAMPLE-HD menu attached to an object prototype: the values each property may take.

    A property with one allowed value is fixed; with several it is randomised. ``pairs`` lists the
    colour/material combinations that are allowed together (a knife is metal; transparent only
    with glass).

    Attributes:
        colour: allowed colour names.
        material: allowed material names.
        size: allowed size names.
        pairs: allowed (colour, material) combinations.
    """

    colour: tuple[str, ...]
    material: tuple[str, ...]
    size: tuple[str, ...]
    pairs: tuple[tuple[str, str], ...] = ()

    def randomised(self) -> tuple[str, ...]:
        """Names of the properties that take more than one value."""
        return tuple(p for p in PROPERTIES if len(getattr(self, p)) > 1)

    def allows(self, colour: str, material: str, size: str) -> bool:
        """Whether the combination is on this menu."""
        return size in self.size and (colour, material) in self.pairs

    def to_dict(self) -> dict[str, list[str]]:
        """Return the menu as a JSON-ready dict (pairs are implied by the catalogue)."""
        return {"colour": list(self.colour), "material": list(self.material), "size": list(self.size)}


@dataclass(frozen=True)
class Variant:
    """A shape variant of a class.

    Attributes:
        name: variant name (e.g. "tapered").
        geometry: procedural (or imported) geometry parameters at real-world size [m].
        affordances: affordances of this variant.
        menu: the asset menu of this variant.
    """

    name: str
    geometry: GeometrySpec
    affordances: Affordances
    menu: AssetMenu


@dataclass(frozen=True)
class ObjectClass:
    """An object class (prototype) with its variants.

    Attributes:
        name: class name used in scenes and instructions (e.g. "wine_glass").
        description: a short noun phrase.
        mass: how the mass is computed.
        variants: variants by name, in file order.
        imported: True for a class registered with ``samplehd assets import``.
    """

    name: str
    description: str
    mass: MassModel
    variants: dict[str, Variant] = field(hash=False)
    imported: bool = False

    def variant(self, name: str) -> Variant:
        """Return the variant ``name``; AssetError naming the valid variants if unknown."""
        try:
            return self.variants[name]
        except KeyError:
            raise AssetError(
                f"unknown variant {name!r} of class {self.name!r}; valid variants are {', '.join(self.variants)}"
            ) from None


@dataclass(frozen=True)
class Catalogue:
    """Everything known about objects: vocabulary values and classes.

    Attributes:
        colours: colours by name.
        materials: materials by name.
        sizes: size classes by name (small, medium, large).
        weights: weight classes, lightest first.
        classes: object classes by name (built-in first, then imported).
        digests: content hashes of what it was read from: ``built-in`` (the data files) and one per
            imported class (its registry files).
        name: which built-in catalogue the classes come from (``procedural`` or ``shop-vrb``).
    """

    colours: dict[str, Colour] = field(hash=False)
    materials: dict[str, Material] = field(hash=False)
    sizes: dict[str, SizeClass] = field(hash=False)
    weights: tuple[WeightClass, ...]
    classes: dict[str, ObjectClass] = field(hash=False)
    digests: dict[str, str] = field(default_factory=dict, hash=False, compare=False)
    name: str = "procedural"

    def record(self) -> CatalogueRecord:
        """What this catalogue was read from, for a dataset's or report's metadata.

        Returns:
            ``{"name": <built-in catalogue>, "sha256": <hash of all below>, "built_in": <hash of the
            data files>, "imported": {class: <hash of its registry files>}}`` (imported: only the
            classes held). The procedural catalogue's sha256 is the same as before catalogues had names.
        """
        imported = {k: v for k, v in sorted(self.digests.items()) if k != "built-in"}
        built_in = self.digests.get("built-in", "")
        whole = hashlib.sha256(json.dumps([built_in, imported], sort_keys=True).encode()).hexdigest()
        return {"name": self.name, "sha256": whole, "built_in": built_in, "imported": imported}

    def object_class(self, name: str) -> ObjectClass:
        """Return the class ``name``; AssetError naming the valid classes if unknown."""
        try:
            return self.classes[name]
        except KeyError:
            raise AssetError(f"unknown object class {name!r}; valid classes are {', '.join(self.classes)}") from None

    def colour(self, name: str) -> Colour:
        """Return the colour ``name``; AssetError naming the valid colours if unknown."""
        return _lookup(self.colours, name, "colour")

    def material(self, name: str) -> Material:
        """Return the material ``name``; AssetError naming the valid materials if unknown."""
        return _lookup(self.materials, name, "material")

    def size(self, name: str) -> SizeClass:
        """Return the size class ``name``; AssetError naming the valid sizes if unknown."""
        return _lookup(self.sizes, name, "size")

    def compatible(self, colour: str, material: str) -> bool:
        """Whether a colour may be combined with a material (both must exist)."""
        c, m = self.colour(colour), self.material(material)
        return (not c.materials or material in c.materials) and (not m.colours or colour in m.colours)

    def weight_class(self, mass: float) -> str:
        """Return the name of the weight class of an object of ``mass`` [kg]."""
        for w in self.weights:
            if w.max_mass is None or mass < w.max_mass:
                return w.name
        return self.weights[-1].name


def _lookup(table: dict, name: str, what: str):  # noqa: ANN202 - generic over the value type
    try:
        return table[name]
    except KeyError:
        raise AssetError(f"unknown {what} {name!r}; valid {what}s are {', '.join(table)}") from None
