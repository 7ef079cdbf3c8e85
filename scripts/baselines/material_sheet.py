"""Contact sheet of every object class in every material it comes in, seen by the scene camera.

One object at a time stands at the middle of the table (the catalogue's first variant, medium size, the
colour most of the class's materials share, so that only the material differs along a row) and is
rendered by the dataset's default scene camera at the dataset's 640x360. Each tile is the crop around
the object, enlarged; rows are classes, columns materials (blank: the class has no such material).

usage: python scripts/baselines/material_sheet.py OUT.png [--preset fast|hd] [--tile 128] [--yaw DEG]
       [--catalogue shop-vrb|procedural]
"""

from __future__ import annotations

import argparse
import math
from collections import Counter

import numpy as np
from PIL import Image, ImageDraw

from samplehd.catalogue import load_catalogue
from samplehd.catalogue.instance import ObjectInstance
from samplehd.catalogue.loader import CATALOGUES, DEFAULT_CATALOGUE
from samplehd.render.contact_sheet import contact_sheet
from samplehd.render.renderer import SceneRenderer
from samplehd.scene.sampler import SCENE_CAMERA
from samplehd.scene.spec import SceneObject, SceneSpec, compile_scene
from samplehd.scene.world import OPERATOR_CAMERA, CameraSpec
from samplehd.world.layout import LAYOUT

MATERIALS = ("metal", "plastic", "ceramic", "rubber", "glass", "wooden")


def _colour(pairs: list[tuple[str, str]]) -> str:
    """The colour most materials of a class share (ties: a saturated one before metallic/white/black)."""
    count = Counter(c for c, _ in pairs)
    order = ["red", "blue", "green", "yellow", "purple", "cyan", "brown", "white", "black", "metallic",
             "transparent"]
    return max(count, key=lambda c: (count[c], -order.index(c) if c in order else -99))


def _tile(model_data: tuple, preset: str, tile: int) -> np.ndarray:
    model, data = model_data
    with SceneRenderer(model, 640, 360, preset) as r:
        img = r.render(data, SCENE_CAMERA, ("rgb", "segmentation"))
    rows, cols = np.nonzero(img["segmentation"] >= 3)
    if len(rows) == 0:
        return np.zeros((tile, tile, 3), np.uint8)
    cr, cc = (rows.min() + rows.max()) // 2, (cols.min() + cols.max()) // 2
    half = max(rows.max() - rows.min(), cols.max() - cols.min(), 24) * 0.65
    r0, c0 = int(max(cr - half, 0)), int(max(cc - half, 0))
    crop = img["rgb"][r0:int(cr + half), c0:int(cc + half)]
    return np.asarray(Image.fromarray(crop).resize((tile, tile), Image.NEAREST))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--preset", default="fast")
    ap.add_argument("--tile", type=int, default=128)
    ap.add_argument("--yaw", type=float, default=30.0)
    ap.add_argument("--classes", nargs="*")
    ap.add_argument("--colour")
    ap.add_argument("--catalogue", choices=list(CATALOGUES), default=DEFAULT_CATALOGUE)
    args = ap.parse_args()
    cat = load_catalogue(name=args.catalogue)
    camera = CameraSpec(SCENE_CAMERA, OPERATOR_CAMERA.pos, OPERATOR_CAMERA.target, OPERATOR_CAMERA.fovy)
    half = math.radians(args.yaw) / 2
    quat = (math.cos(half), 0.0, 0.0, math.sin(half))
    tiles, labels = [], []
    for name in args.classes or sorted(cat.classes):
        cls = cat.object_class(name)
        variant = next(iter(cls.variants))
        pairs = list(cls.variant(variant).menu.pairs)
        colour = args.colour or _colour(pairs)
        for material in MATERIALS:
            options = [c for c, m in pairs if m == material]
            if not options:
                tiles.append(np.full((args.tile, args.tile, 3), 255, np.uint8))
                labels.append("")
                continue
            c = colour if colour in options else options[0]
            inst = ObjectInstance(name, variant, c, material, "medium")
            scene = SceneSpec(0, 0, (SceneObject(inst, (0.0, 0.0, LAYOUT.table_height + 0.0005), quat),), camera)
            tiles.append(_tile(compile_scene(scene), args.preset, args.tile))
            labels.append(f"{name[:9]} {material[:5]} {c[:5]}")
    sheet = Image.fromarray(contact_sheet(tiles, len(MATERIALS)))
    draw = ImageDraw.Draw(sheet)
    for k, label in enumerate(labels):
        if label:
            x, y = (k % len(MATERIALS)) * (args.tile + 4), (k // len(MATERIALS)) * (args.tile + 4)
            draw.rectangle((x, y, x + 6 * len(label) + 6, y + 14), fill=(0, 0, 0))
            draw.text((x + 3, y + 2), label, fill=(255, 255, 255))
    sheet.save(args.out)
    print(args.out, sheet.size)


if __name__ == "__main__":
    main()
