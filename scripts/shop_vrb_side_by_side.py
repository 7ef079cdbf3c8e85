"""One seeded shop-vrb scene, and the same scene with each object's procedural counterpart (same class,
colour, material and size where its menu has them, same pose), side by side (hd preset, scene camera).

    python scripts/shop_vrb_side_by_side.py docs/images/catalogues_side_by_side.png [SEED]
"""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import dataclasses
import sys

import numpy as np
from PIL import Image

from samplehd.catalogue import ObjectInstance, load_catalogue
from samplehd.render.renderer import SceneRenderer
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import compile_scene


def _procedural(inst: ObjectInstance) -> ObjectInstance:
    cls = load_catalogue().classes[inst.class_name]
    v = next(iter(cls.variants.values()))
    colour, material = (inst.colour, inst.material) if (inst.colour, inst.material) in v.menu.pairs \
        else v.menu.pairs[0]
    return ObjectInstance(inst.class_name, v.name, colour, material, inst.size if inst.size in v.menu.size
                          else v.menu.size[0])


def main(out: str, seed: int = 7) -> None:
    shop = sample_scene(0, seed, SceneConfig(catalogue="shop-vrb", min_objects=5, max_objects=5)).scene
    old = dataclasses.replace(shop, objects=tuple(dataclasses.replace(o, instance=_procedural(o.instance))
                                                  for o in shop.objects))
    images = []
    for scene in (old, shop):
        model, data = compile_scene(scene)
        with SceneRenderer(model, 640, 360, "hd") as renderer:
            images.append(renderer.render(data, "scene", ("rgb",))["rgb"])
    print([o.instance.class_name for o in shop.objects])
    Image.fromarray(np.concatenate(images, axis=1)).save(out, optimize=True)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "docs/images/catalogues_side_by_side.png",
         int(sys.argv[2]) if len(sys.argv) > 2 else 7)
