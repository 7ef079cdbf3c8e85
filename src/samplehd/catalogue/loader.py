"""Load and validate the catalogue data files; merge built-in and user-registered classes.

Files (in ``samplehd/catalogue/data`` unless another directory is given):
    colours.json    ``{"format": 1, "colours": {name: {"rgba": [r, g, b, a], "materials"?: [...]}}}``
    materials.json  ``{"format": 1, "materials": {name: {"look": {...}, "physics": {...}, "colours"?: [...]}}}``
    sizes.json      ``{"format": 1, "sizes": {name: {"scale": s}}, "weights": {name: {"max_mass": kg|null}}}``
    classes.json    ``{"format": 1, "classes": {name: {description, affordances, mass, variants, menu}}}``

Two built-in catalogues share the colours, materials and sizes: ``procedural`` (``classes.json``,
shapes made from a few numbers) and ``shop-vrb`` (``shop_vrb/classes.json``, SAMPLE-HD's SHOP-VRB
shapes vendored from MuBlE, see ``shop_vrb/files.md``). Their variant names differ (``shopvrb1``,
... in ``shop-vrb``), so an :class:`~samplehd.catalogue.instance.ObjectInstance` says by its variant
which catalogue it comes from (:func:`resolve_catalogue`).

Imported classes live in the user registry (see :mod:`samplehd.catalogue.registry`) and in the
shipped pack (``data/imported_pack``: meshes from outside both built-in catalogues, written by
``scripts/vendor_imported_pack.py`` with the importer, see ``imported_pack/files.md``), one
``<name>/class.json`` each with the same layout as one entry of ``classes.json``. A catalogue holds
the built-in classes and only those imported classes that are asked for by name, and records a
content hash of its data files and of every imported class it holds (:meth:`Catalogue.record`). A
pack class's name is reserved (the importer refuses it), and a name in both the pack and the user
registry is the pack's, so a name means the same shape on every machine.

Every problem is reported as one :class:`~samplehd.errors.AssetError` line naming the file, the
field and what is valid; unknown keys are errors.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from functools import lru_cache
from pathlib import Path

from samplehd.catalogue.geometry import parse_geometry
from samplehd.catalogue.model import (
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
from samplehd.catalogue.registry import generation, registered_classes, registry_dir
from samplehd.catalogue.schema import Field, read_json
from samplehd.catalogue.textures import TEXTURES
from samplehd.errors import AssetError
from samplehd.fileio import file_sha256

__all__ = [
    "CATALOGUES",
    "DATA_DIR",
    "DEFAULT_CATALOGUE",
    "LEGACY_CATALOGUE",
    "TEXTURES",
    "catalogue_for",
    "load_catalogue",
    "pack_classes",
    "parse_class",
    "read_catalogue",
    "resolve_catalogue",
]

DATA_DIR = Path(__file__).parent / "data"
# The shipped pack of imported classes, relative to the data directory.
PACK = "imported_pack"
FORMAT = 1
_AFFORDANCES = ("graspable", "handle_pickable", "container", "stackable_on", "stackable")


_DATA_FILES = ("colours.json", "materials.json", "sizes.json", "classes.json")
_SHARED_FILES = ("colours.json", "materials.json", "sizes.json")
# Built-in catalogue name -> its classes file, relative to the data directory.
CATALOGUES: dict[str, str] = {"procedural": "classes.json", "shop-vrb": "shop_vrb/classes.json"}
# The one declaration of the default: SAMPLE-HD's own shapes. Every config, preset, command and the
# environment take it from here; ``procedural`` is chosen by name (``scene.catalogue: procedural``).
DEFAULT_CATALOGUE = "shop-vrb"
# What a record written before catalogues had names was drawn from.
LEGACY_CATALOGUE = "procedural"


def load_catalogue(imported: Iterable[str] = (), name: str = DEFAULT_CATALOGUE) -> Catalogue:
    """Return the built-in catalogue ``name`` plus the imported classes named in ``imported`` (cached):
    classes of the shipped pack (:func:`pack_classes`) or of the user registry.

    Nothing in the user registry takes part unless named here, so a seeded run gives the same
    scenes on every machine whatever its user imported. Call
    :func:`~samplehd.catalogue.registry.refresh` after the registry changes (``assets import`` and
    ``assets remove`` do).

    Args:
        imported: names of classes in the user registry to add.
        name: built-in catalogue, one of :data:`CATALOGUES` (``procedural`` or ``shop-vrb``).

    Raises:
        AssetError: a data file or a named class is malformed, a name is not in the registry, or
            ``name`` is not a built-in catalogue.
    """
    _check_name(name)
    return _load_cached(str(DATA_DIR), str(registry_dir()), tuple(sorted(set(imported))), generation(), name)


@lru_cache(maxsize=4)
def pack_classes(data_dir: Path = DATA_DIR) -> tuple[str, ...]:
    """Names of the imported classes shipped in the pack (``data/imported_pack``), sorted. The pack is
    package data, so its listing is read once per directory."""
    return registered_classes(Path(data_dir) / PACK)


def catalogue_for(class_names: Iterable[str], name: str = DEFAULT_CATALOGUE) -> Catalogue:
    """The catalogue a config naming ``class_names`` needs: the built-in catalogue ``name`` plus
    every named class found in the shipped pack or the user registry. Names found in none are left to
    the caller's validation, which knows the file and field to name.
    """
    builtin = load_catalogue(name=name)
    wanted = [n for n in class_names if n not in builtin.classes]
    if not wanted:
        return builtin
    known = {*pack_classes(), *registered_classes()}
    return load_catalogue((n for n in wanted if n in known), name)


def resolve_catalogue(
    catalogue: Catalogue | None, class_names: Iterable[str] = (), variant: str | None = None
) -> Catalogue:
    """``catalogue`` if given, else :func:`catalogue_for` the classes a caller is about to use, from
    the built-in catalogue that holds ``variant`` of the (first) class: variant names are unique
    across the built-in catalogues, so an instance knows where its shape comes from."""
    if catalogue is not None:
        return catalogue
    names = tuple(class_names)
    cat = catalogue_for(names)
    if variant is None or not names or names[0] not in cat.classes or variant in cat.classes[names[0]].variants:
        return cat
    for other in CATALOGUES:
        if other != DEFAULT_CATALOGUE:
            alt = catalogue_for(names, other)
            if names[0] in alt.classes and variant in alt.classes[names[0]].variants:
                return alt
    return cat


def _check_name(name: str) -> None:
    if name not in CATALOGUES:
        raise AssetError(f"unknown catalogue {name!r}; valid catalogues are {', '.join(CATALOGUES)}")


@lru_cache(maxsize=8)
def _load_cached(data_dir: str, registry: str, imported: tuple[str, ...], _generation: int, name: str) -> Catalogue:
    return read_catalogue(Path(data_dir), Path(registry), imported, name)


def read_catalogue(
    data_dir: Path = DATA_DIR,
    registry: Path | None = None,
    imported: Iterable[str] = (),
    name: str = DEFAULT_CATALOGUE,
) -> Catalogue:
    """Read and validate the catalogue files in ``data_dir`` and the named imported classes.

    Args:
        data_dir: directory holding colours.json, materials.json, sizes.json, the classes files and
            the pack of imported classes.
        registry: user registry directory with imported classes (default :func:`registry_dir`).
        imported: names of the pack's or the registry's classes to add (default: none); a name in
            both is the pack's.
        name: which built-in catalogue's classes to read (:data:`CATALOGUES`).

    Returns:
        The validated catalogue, with the content hashes of what it was read from.

    Raises:
        AssetError: a file is missing or malformed (one line naming file and field), or a named
            class is not in the registry.
    """
    data_dir = Path(data_dir)
    colours = _read_colours(read_json(data_dir / "colours.json"))
    materials = _read_materials(read_json(data_dir / "materials.json"), colours)
    sizes, weights = _read_sizes(read_json(data_dir / "sizes.json"))
    base = Catalogue(colours, materials, sizes, weights, {})
    _check_name(name)
    classes_file = data_dir / CATALOGUES[name]
    doc = read_json(classes_file).mapping(["format", "classes"])
    _check_format(doc["format"])
    classes: dict[str, ObjectClass] = {}
    for cname, entry in doc["classes"].items():
        classes[cname] = parse_class(base, entry, name=cname, registry_dir=classes_file.parent)
    if not classes:
        raise doc["classes"].fail("expected at least one class")
    if name == LEGACY_CATALOGUE:  # hashed as before catalogues had names, so old records still match
        built_in = _digest(data_dir / f for f in _DATA_FILES)
    else:  # the shared vocabulary, the classes file and every mesh file it names
        meshes = sorted(p for p in classes_file.parent.iterdir() if p.suffix == ".npz")
        built_in = _digest([*(data_dir / f for f in _SHARED_FILES), classes_file, *meshes])
    digests = {"built-in": built_in}
    names = tuple(dict.fromkeys(imported))
    if names:
        registry = registry_dir() if registry is None else Path(registry)
        pack = pack_classes(data_dir)
        known = registered_classes(registry)
        for cname in names:
            if cname not in pack and cname not in known:
                raise AssetError(
                    f"class {cname!r}: neither built-in nor imported into {registry}; built-in classes: "
                    f"{', '.join(classes)}; shipped imported: {', '.join(pack) or 'none'}; imported: "
                    f"{', '.join(known) or 'none'} (add one with `samplehd assets import`)"
                )
        for cname in names:
            path = (data_dir / PACK if cname in pack else registry) / cname / "class.json"
            f = read_json(path)
            if cname in classes:
                raise f.fail(f"imported class {cname!r} clashes with a built-in class; re-import under another name")
            classes[cname] = parse_class(base, f, name=cname, imported=True, registry_dir=path.parent)
            digests[cname] = _digest(sorted(p for p in path.parent.iterdir() if p.is_file()))
    return Catalogue(colours, materials, sizes, weights, classes, digests, name)


def _digest(paths: Iterable[Path]) -> str:
    """SHA-256 over the names and contents of ``paths`` (in the given order)."""
    h = hashlib.sha256()
    for p in paths:
        h.update(f"{p.name}\0{file_sha256(p)}\n".encode())
    return h.hexdigest()


def _check_format(f: Field) -> None:
    if f.value != FORMAT:
        raise f.fail(f"unsupported format {f.value!r}; this samplehd reads format {FORMAT}")


def _read_colours(doc: Field) -> dict[str, Colour]:
    m = doc.mapping(["format", "colours"])
    _check_format(m["format"])
    out: dict[str, Colour] = {}
    for name, entry in m["colours"].items():
        e = entry.mapping(["rgba"], ["materials"])
        entry.child("name", name).name()
        rgba = e["rgba"].numbers(4, 0.0, 1.0)
        mats = tuple(f.name() for f in e["materials"].sequence(1)) if "materials" in e else ()
        out[name] = Colour(name, (rgba[0], rgba[1], rgba[2], rgba[3]), mats)
    if not out:
        raise m["colours"].fail("expected at least one colour")
    return out


def _read_materials(doc: Field, colours: dict[str, Colour]) -> dict[str, Material]:
    m = doc.mapping(["format", "materials"])
    _check_format(m["format"])
    out: dict[str, Material] = {}
    for name, entry in m["materials"].items():
        entry.child("name", name).name()
        e = entry.mapping(["look", "physics"], ["colours"])
        look = e["look"].mapping(["specular", "shininess", "reflectance"], ["alpha", "texture"])
        phys = e["physics"].mapping(["density", "friction"], ["sheet_factor"])
        friction = phys["friction"].numbers(3, 0.0, 10.0)
        if friction[0] <= 0:
            raise phys["friction"].fail("sliding friction (first value) must be > 0")
        density = phys["density"].number(1.0, 25000.0)
        out[name] = Material(
            name=name,
            specular=look["specular"].number(0.0, 1.0),
            shininess=look["shininess"].number(0.0, 1.0),
            reflectance=look["reflectance"].number(0.0, 1.0),
            alpha=look["alpha"].number(0.05, 1.0) if "alpha" in look else 1.0,
            texture=look["texture"].choice(tuple(TEXTURES)) if "texture" in look else None,
            density=density,
            friction=(friction[0], friction[1], friction[2]),
            sheet_factor=phys["sheet_factor"].number(0.01, 1.0) if "sheet_factor" in phys else 1.0,
            colours=e["colours"].choices(colours) if "colours" in e else (),
        )
    for c in colours.values():
        for mat in c.materials:
            if mat not in out:
                raise Field(None, "colours.json", f"colours.{c.name}.materials").fail(
                    f"unknown material {mat!r}; valid materials are {', '.join(out)}"
                )
    return out


def _read_sizes(doc: Field) -> tuple[dict[str, SizeClass], tuple[WeightClass, ...]]:
    m = doc.mapping(["format", "sizes", "weights"])
    _check_format(m["format"])
    sizes = {}
    for name, entry in m["sizes"].items():
        entry.child("name", name).name()
        sizes[name] = SizeClass(name, entry.mapping(["scale"])["scale"].number(0.2, 5.0))
    if not sizes:
        raise m["sizes"].fail("expected at least one size")
    weights: list[WeightClass] = []
    for name, entry in m["weights"].items():
        entry.child("name", name).name()
        f = entry.mapping(["max_mass"])["max_mass"]
        limit = None if f.value is None else f.positive()
        if weights and (weights[-1].max_mass is None or (limit is not None and limit <= weights[-1].max_mass)):
            raise f.fail("weight classes must be listed lightest first with increasing max_mass; only the last is null")
        weights.append(WeightClass(name, limit))
    if not weights or weights[-1].max_mass is not None:
        raise m["weights"].fail("the last weight class must have max_mass null (no upper bound)")
    return sizes, tuple(weights)


def parse_class(
    catalogue: Catalogue,
    f: Field,
    *,
    name: str,
    imported: bool = False,
    registry_dir: Path | None = None,
) -> ObjectClass:
    """Validate one class entry against the vocabulary of ``catalogue``.

    Args:
        catalogue: provides colours, materials and sizes (its classes are ignored).
        f: the class entry.
        name: class name.
        imported: whether the class comes from the user registry.
        registry_dir: directory that relative mesh paths of an imported class are resolved against.

    Raises:
        AssetError: the entry is malformed (one line naming the file and field).
    """
    f.child("name", name).name()
    e = f.mapping(["description", "affordances", "mass", "variants", "menu"])
    description = e["description"].string()
    affordances = _affordances(e["affordances"])
    mass = _mass(e["mass"])
    menu = _menu(catalogue, e["menu"])
    variants: dict[str, Variant] = {}
    for vname, ventry in e["variants"].items():
        ventry.child("name", vname).name()
        v = ventry.mapping(["geometry"], ["affordances", "menu"])
        variants[vname] = Variant(
            name=vname,
            geometry=parse_geometry(v["geometry"], registry_dir),
            affordances=_affordances(v["affordances"]) if "affordances" in v else affordances,
            menu=_menu(catalogue, v["menu"], base=menu) if "menu" in v else menu,
        )
    if not variants:
        raise e["variants"].fail("expected at least one variant")
    return ObjectClass(name, description, mass, variants, imported)


def _affordances(f: Field) -> Affordances:
    m = f.mapping(_AFFORDANCES)
    return Affordances(**{k: m[k].boolean() for k in _AFFORDANCES})


def _mass(f: Field) -> MassModel:
    m = f.mapping(["thin_walled"], ["shell", "contents_density", "fill"])
    return MassModel(
        thin_walled=m["thin_walled"].boolean(),
        shell=m["shell"].number(1e-5, 0.05, lo_open=True) if "shell" in m else None,
        contents_density=m["contents_density"].number(0.0, 20000.0) if "contents_density" in m else 0.0,
        fill=m["fill"].number(0.0, 1.0) if "fill" in m else 1.0,
    )


def _menu(catalogue: Catalogue, f: Field, base: AssetMenu | None = None) -> AssetMenu:
    """Parse a menu; with ``base`` (a variant's override) missing properties come from it."""
    m = f.mapping([] if base else ["colour", "material", "size"], [] if not base else ["colour", "material", "size"])
    colour = m["colour"].choices(catalogue.colours) if "colour" in m else base.colour  # type: ignore[union-attr]
    material = (
        m["material"].choices(catalogue.materials) if "material" in m else base.material  # type: ignore[union-attr]
    )
    size = m["size"].choices(catalogue.sizes) if "size" in m else base.size  # type: ignore[union-attr]
    return make_menu(catalogue, colour, material, size, f)


def make_menu(
    catalogue: Catalogue,
    colour: tuple[str, ...],
    material: tuple[str, ...],
    size: tuple[str, ...],
    where: Field,
) -> AssetMenu:
    """Build a menu and check that every colour and every material can be combined with the other.

    Args:
        catalogue: provides the colour/material compatibility rules.
        colour: allowed colours.
        material: allowed materials.
        size: allowed sizes.
        where: field to name in error messages.

    Raises:
        AssetError: a colour fits none of the materials or a material none of the colours.
    """
    pairs = tuple((c, m) for c in colour for m in material if catalogue.compatible(c, m))
    for c in colour:
        if not any(p[0] == c for p in pairs):
            raise where.child("colour", None).fail(
                f"colour {c!r} fits none of the materials {list(material)}"
                f" (it needs one of {list(catalogue.colours[c].materials) or 'any'})"
            )
    for mat in material:
        if not any(p[1] == mat for p in pairs):
            raise where.child("material", None).fail(
                f"material {mat!r} fits none of the colours {list(colour)}"
                f" (it allows {list(catalogue.materials[mat].colours) or 'any'})"
            )
    return AssetMenu(colour, material, size, pairs)
