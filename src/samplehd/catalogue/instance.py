"""``ObjectInstance``: one concrete object (class, variant, colour, material, size) of a scene."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from samplehd.catalogue.loader import resolve_catalogue
from samplehd.catalogue.model import Catalogue
from samplehd.errors import AssetError

__all__ = ["ObjectInstance"]

_FIELDS = ("class_name", "variant", "colour", "material", "size")


@dataclass(frozen=True)
class ObjectInstance:
    """A concrete object: which prototype and which menu choices.

    Attributes:
        class_name: object class (e.g. "mug").
        variant: shape variant of the class (e.g. "tapered").
        colour: colour name.
        material: material name.
        size: size class name (small, medium, large).
    """

    class_name: str
    variant: str
    colour: str
    material: str
    size: str

    def __post_init__(self) -> None:
        for name in _FIELDS:
            value = getattr(self, name)
            if not isinstance(value, str) or not value:
                raise AssetError(f"ObjectInstance.{name}: expected a non-empty string, got {value!r}")

    def validate(self, catalogue: Catalogue | None = None) -> ObjectInstance:
        """Check every field against the catalogue and the colour/material rules; return self.

        Args:
            catalogue: catalogue to check against (default: :func:`load_catalogue`).

        Raises:
            AssetError: an unknown name or a colour that does not go with the material.
        """
        catalogue = resolve_catalogue(catalogue, (self.class_name,), self.variant)
        catalogue.object_class(self.class_name).variant(self.variant)
        catalogue.colour(self.colour)
        catalogue.material(self.material)
        catalogue.size(self.size)
        if not catalogue.compatible(self.colour, self.material):
            valid = [c for c in catalogue.colours if catalogue.compatible(c, self.material)]
            raise AssetError(
                f"colour {self.colour!r} cannot be combined with material {self.material!r}; "
                f"{self.material} allows {', '.join(valid)}"
            )
        return self

    def to_dict(self) -> dict[str, str]:
        """Return the instance as a JSON-ready dict with keys class_name, variant, colour, material, size."""
        return {name: getattr(self, name) for name in _FIELDS}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], catalogue: Catalogue | None = None) -> ObjectInstance:
        """Build and validate an instance from :meth:`to_dict` output.

        Args:
            data: mapping with exactly the keys class_name, variant, colour, material, size.
            catalogue: catalogue to validate against (default: :func:`load_catalogue`).

        Raises:
            AssetError: missing or unknown keys, or invalid values.
        """
        if not isinstance(data, Mapping):
            raise AssetError(f"ObjectInstance: expected an object with keys {', '.join(_FIELDS)}, got {data!r}")
        unknown = sorted(set(data) - set(_FIELDS))
        if unknown:
            raise AssetError(f"ObjectInstance: unknown key {unknown[0]!r}; valid keys are {', '.join(_FIELDS)}")
        missing = [k for k in _FIELDS if k not in data]
        if missing:
            raise AssetError(f"ObjectInstance: missing key {missing[0]!r}; required keys are {', '.join(_FIELDS)}")
        return cls(**{k: data[k] for k in _FIELDS}).validate(catalogue)
