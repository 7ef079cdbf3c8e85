"""Manage object assets: import any mesh as a new class, list the catalogue, render a preview.

Examples::

    samplehd assets import teapot.obj --name teapot --size 0.2 --material ceramic metal
    samplehd assets list
    samplehd assets preview mug --out mug.png --colour red --material ceramic --size large
    samplehd assets sheet --out docs/images/catalogue.png
    samplehd assets preview mug --catalogue shop-vrb --out mug.png
    samplehd assets remove teapot

Imported classes are stored in $SAMPLEHD_REGISTRY_DIR (default ~/.local/share/samplehd/assets),
convex decompositions are cached in $SAMPLEHD_CACHE_DIR (default ~/.cache/samplehd).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from PIL import Image

from samplehd.catalogue.instance import ObjectInstance
from samplehd.catalogue.loader import CATALOGUES, DEFAULT_CATALOGUE, catalogue_for, load_catalogue, pack_classes
from samplehd.catalogue.preview import render_instances, write_catalogue_table
from samplehd.catalogue.registry import registered_classes, remove_imported
from samplehd.commands._options import (
    DefaultsHelpFormatter,
    check_int,
    check_out_file,
    config_from_options,
    split_names,
)
from samplehd.dataset.outputs import check_outputs
from samplehd.errors import AssetError

HELP = "import meshes as object classes, list the catalogue, render previews"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the ``import``, ``list``, ``preview``, ``sheet`` and ``remove`` sub-commands."""
    parser.formatter_class = argparse.RawDescriptionHelpFormatter  # keep the examples' line breaks
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    fmt = DefaultsHelpFormatter

    p = sub.add_parser("import", help="import an OBJ/STL/PLY/GLB mesh as a new object class", formatter_class=fmt)
    p.add_argument("mesh", type=Path, metavar="MESH", help="mesh file (.obj, .stl, .ply, .glb)")
    p.add_argument("--name", required=True, help="new class name (lower-case snake case)")
    p.add_argument("--scale", type=float, default=None, help="file units to metres (0.001 for mm)")
    p.add_argument("--size", type=float, default=None, help="target largest extent after scaling [m]")
    p.add_argument("--material", nargs="+", default=["plastic"], help="materials of the asset menu")
    p.add_argument("--colour", nargs="+", default=None, help="colours of the menu (default: all that fit)")
    p.add_argument("--sizes", nargs="+", default=None, help="size classes of the menu (default: all)")
    p.add_argument("--description", default=None, help="short noun phrase describing the object")
    p.add_argument("--threshold", type=float, default=0.05, help="CoACD concavity threshold")
    p.add_argument("--max-pieces", type=int, default=16, help="most convex collision pieces")
    p.add_argument("--overwrite", action="store_true", help="replace a class already registered under NAME")

    p = sub.add_parser("list", help="list object classes, variants and menus", formatter_class=fmt)
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    _catalogue_flag(p)

    p = sub.add_parser("preview", help="render all variants of a class to a PNG", formatter_class=fmt)
    p.add_argument("name", metavar="NAME", help="class name")
    p.add_argument("--out", type=Path, required=True, help="output PNG file")
    p.add_argument("--colour", default=None, help="colour (default: the first of the menu)")
    p.add_argument("--material", default=None, help="material (default: the first that fits the colour)")
    p.add_argument("--size", default="medium", help="size class")
    p.add_argument("--width", type=int, default=640, help="image width [px]")
    p.add_argument("--height", type=int, default=480, help="image height [px]")
    _catalogue_flag(p)

    p = sub.add_parser("sheet", help="render the contact sheet of all classes x materials", formatter_class=fmt)
    p.add_argument("--out", type=Path, required=True, help="output PNG file")
    _catalogue_flag(p)

    p = sub.add_parser("remove", help="remove an imported class from the registry", formatter_class=fmt)
    p.add_argument("name", metavar="NAME", help="imported class name")


def run(args: argparse.Namespace) -> int:
    """Run the chosen action; returns the exit status."""
    return {"import": _import, "list": _list, "preview": _preview, "sheet": _sheet, "remove": _remove}[args.action](
        args
    )


def _import(args: argparse.Namespace) -> int:
    from samplehd.catalogue.importer import ImportOptions, import_mesh  # the mesh extra (trimesh, coacd)

    options = config_from_options(ImportOptions, scale=args.scale, size=args.size, threshold=args.threshold,
                                  max_pieces=args.max_pieces)
    cls, report = import_mesh(
        args.mesh,
        args.name,
        options=options,
        materials=split_names(args.material, "--material") or ("plastic",),
        colours=split_names(args.colour, "--colour"),
        sizes=split_names(args.sizes, "--sizes"),
        description=args.description,
        overwrite=args.overwrite,
    )
    ext = " x ".join(f"{e * 100:.1f}" for e in report["extents"])
    print(
        f"imported {cls.name}: {ext} cm, {report['pieces']} convex pieces"
        f"{' (cached)' if report['cached'] else ''}, graspable={report['graspable']}, "
        f"{report['seconds']:.2f} s -> {report['registry']}"
    )
    return 0


def _catalogue_flag(p: argparse.ArgumentParser) -> None:
    p.add_argument("--catalogue", choices=list(CATALOGUES), default=DEFAULT_CATALOGUE,
                   help="built-in catalogue: SAMPLE-HD's SHOP-VRB models (default) or procedural shapes")


def _list(args: argparse.Namespace) -> int:
    cat = load_catalogue((*pack_classes(), *registered_classes()), args.catalogue)
    rows = []
    for cls in cat.classes.values():
        for v in cls.variants.values():
            rows.append(
                {
                    "class": cls.name,
                    "variant": v.name,
                    "imported": cls.imported,
                    "menu": v.menu.to_dict(),
                    "affordances": v.affordances.to_dict(),
                }
            )
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print(f"{'class':16s} {'variant':12s} {'src':4s} {'materials':32s} {'sizes':20s} colours")
    for r in rows:
        m = r["menu"]
        print(
            f"{r['class']:16s} {r['variant']:12s} {'imp' if r['imported'] else 'std':4s} "
            f"{','.join(m['material']):32s} {','.join(m['size']):20s} {','.join(m['colour'])}"
        )
    return 0


def _preview(args: argparse.Namespace) -> int:
    check_int("--width", args.width, 16, 4096)
    check_int("--height", args.height, 16, 4096)
    check_out_file("--out", args.out, (".png", ".jpg"))
    check_outputs({"--out": args.out})
    cat = catalogue_for((args.name,), args.catalogue)
    cls = cat.object_class(args.name)
    cat.size(args.size)
    if args.colour is not None:
        cat.colour(args.colour)
    if args.material is not None:
        cat.material(args.material)
    instances = []
    for v in cls.variants.values():
        pairs = [
            (c, m)
            for c, m in v.menu.pairs
            if (args.colour is None or c == args.colour) and (args.material is None or m == args.material)
        ]
        if not pairs and args.colour is not None and args.material is not None:
            pairs = [(args.colour, args.material)]  # off-menu but allowed: previews may show anything valid
        if not pairs:
            raise AssetError(
                f"{cls.name}.{v.name}: no menu entry with colour={args.colour} material={args.material}; "
                f"the menu allows {', '.join(f'{c}/{m}' for c, m in v.menu.pairs)}"
            )
        instances.append(ObjectInstance(cls.name, v.name, pairs[0][0], pairs[0][1], args.size).validate(cat))
    img = render_instances(instances, args.width, args.height, catalogue=cat)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(img).save(args.out)
    print(f"wrote {args.out} ({', '.join(f'{i.variant} {i.colour} {i.material}' for i in instances)})")
    return 0


def _sheet(args: argparse.Namespace) -> int:
    check_out_file("--out", args.out, (".png", ".jpg"))
    check_outputs({"--out": args.out})
    path = write_catalogue_table(args.out, load_catalogue(name=args.catalogue))
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB)")
    return 0


def _remove(args: argparse.Namespace) -> int:
    remove_imported(args.name)
    print(f"removed {args.name}")
    return 0
