"""Per-run overrides of the asset menus (the SAMPLE-HD "menu attached to the object prototype").

An override document maps a target to a partial menu::

    {
      "*":           {"size": ["medium"]},                 # every class and variant
      "mug":         {"colour": ["red", "blue"]},          # every variant of a class
      "mug.tapered": {"material": ["ceramic", "glass"]}    # one variant
    }

Targets apply from general to specific ("*", then class, then class.variant); each property given
replaces the menu's list (it may widen it: any catalogue value is allowed as long as every colour
fits one of the materials and vice versa). Unknown targets, keys or values are errors naming the
field and the valid choices.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from samplehd.catalogue.loader import make_menu, resolve_catalogue
from samplehd.catalogue.model import PROPERTIES, Catalogue, ObjectClass
from samplehd.catalogue.schema import Field
from samplehd.errors import AssetError

__all__ = ["apply_menu_overrides", "validate_menu_overrides"]


def validate_menu_overrides(
    overrides: Mapping[str, Any], catalogue: Catalogue | None = None, *, source: str = "menu overrides"
) -> dict[str, dict[str, tuple[str, ...]]]:
    """Check an override document and return it normalised (targets -> property -> values).

    Args:
        overrides: the document (see the module docstring).
        catalogue: catalogue to check names against (default: :func:`load_catalogue`).
        source: file or option name to put in error messages.

    Raises:
        AssetError: one line naming the target/property at fault and what is valid.
    """
    cat = resolve_catalogue(catalogue, (t.partition('.')[0] for t in overrides if t != '*'))
    root = Field(overrides, source, "")
    out: dict[str, dict[str, tuple[str, ...]]] = {}
    for target, entry in root.items():
        if target != "*":
            cls_name, _, variant = target.partition(".")
            if cls_name not in cat.classes:
                raise entry.fail(
                    f"unknown class {cls_name!r}; valid targets are '*', a class or class.variant "
                    f"with classes {', '.join(cat.classes)}"
                )
            if variant and variant not in cat.classes[cls_name].variants:
                raise entry.fail(
                    f"unknown variant {variant!r} of {cls_name}; valid variants are "
                    f"{', '.join(cat.classes[cls_name].variants)}"
                )
        m = entry.mapping([], PROPERTIES)
        if not m:
            raise entry.fail(f"empty override; give at least one of {', '.join(PROPERTIES)}")
        values = {"colour": cat.colours, "material": cat.materials, "size": cat.sizes}
        out[target] = {p: m[p].choices(values[p]) for p in PROPERTIES if p in m}
    return out


def apply_menu_overrides(
    overrides: Mapping[str, Any], catalogue: Catalogue | None = None, *, source: str = "menu overrides"
) -> Catalogue:
    """Return a catalogue whose variant menus have the overrides applied.

    Args:
        overrides: the override document (see the module docstring); empty returns the catalogue.
        catalogue: catalogue to start from (default: :func:`load_catalogue`).
        source: file or option name to put in error messages.

    Raises:
        AssetError: a malformed override, or a resulting menu whose colours and materials do not fit.
    """
    cat = resolve_catalogue(catalogue, (t.partition('.')[0] for t in overrides if t != '*'))
    norm = validate_menu_overrides(overrides, cat, source=source)
    if not norm:
        return cat
    classes: dict[str, ObjectClass] = {}
    for cname, cls in cat.classes.items():
        variants = {}
        for vname, variant in cls.variants.items():
            menu = variant.menu
            targets = [t for t in ("*", cname, f"{cname}.{vname}") if t in norm]
            if targets:
                props = {p: getattr(menu, p) for p in PROPERTIES}
                for t in targets:
                    props.update(norm[t])
                where = Field(None, source, targets[-1])
                try:
                    menu = make_menu(cat, props["colour"], props["material"], props["size"], where)
                except AssetError as exc:
                    raise AssetError(f"{exc} (in the menu of {cname}.{vname})") from None
            variants[vname] = replace(variant, menu=menu)
        classes[cname] = replace(cls, variants=variants)
    return replace(cat, classes=classes)
