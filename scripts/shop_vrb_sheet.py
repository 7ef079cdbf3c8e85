"""Contact sheet of the ``shop-vrb`` catalogue: every class x variant at 320 x 180, one per cell.

    python scripts/shop_vrb_sheet.py docs/images/shop_vrb_sheet.png [hd|photo|fast]

Each cell shows one variant at medium size (or its largest allowed) in a colour and material of its
menu, rendered with a preset of the dataset (``samplehd.catalogue.preview``; default ``hd``).
"""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import sys
from pathlib import Path

from PIL import Image, ImageDraw

from samplehd.catalogue import ObjectInstance, load_catalogue
from samplehd.catalogue.preview import render_instances

# A look per class that says what it is (colour, material) where its menu has it.
LOOK = {"baking_tray": ("metallic", "metal"), "bowl": ("white", "ceramic"), "chopping_board": ("brown", "wooden"),
        "food_box": ("yellow", "plastic"), "fork": ("metallic", "metal"), "glass": ("transparent", "glass"),
        "knife": ("metallic", "metal"), "mug": ("red", "ceramic"), "pan": ("black", "metal"),
        "plate": ("white", "ceramic"), "scissors": ("red", "plastic"), "soda_can": ("red", "metal"),
        "spoon": ("metallic", "metal"), "thermos": ("blue", "metal"), "wine_glass": ("transparent", "glass")}
W, H, COLS = 320, 180, 6


def main(out: str, preset: str = "hd") -> None:
    cat = load_catalogue(name="shop-vrb")
    cells = []
    for cls in cat.classes.values():
        for v in cls.variants.values():
            colour, material = LOOK[cls.name] if LOOK[cls.name] in v.menu.pairs else v.menu.pairs[0]
            size = "medium" if "medium" in v.menu.size else v.menu.size[-1]
            img = render_instances([ObjectInstance(cls.name, v.name, colour, material, size)], W, H, catalogue=cat,
                                   preset=preset)
            cells.append((f"{cls.name} {v.name}", Image.fromarray(img)))
    rows = -(-len(cells) // COLS)
    sheet = Image.new("RGB", (COLS * W, rows * H), (250, 250, 250))
    draw = ImageDraw.Draw(sheet)
    for k, (label, img) in enumerate(cells):
        x, y = (k % COLS) * W, (k // COLS) * H
        sheet.paste(img, (x, y))
        draw.text((x + 5, y + H - 14), label, fill=(20, 20, 20))
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    sheet.save(out, optimize=True)
    print(f"{out}: {len(cells)} variants")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "docs/images/shop_vrb_sheet.png",
         sys.argv[2] if len(sys.argv) > 2 else "hd")
