"""Procedural vs shop-vrb side by side in one run: scene sampling time and render frame rates.

    python scripts/shop_vrb_speed.py

Scene sampling: seeds 1000..1007 with each catalogue, interleaved. Rendering: three shop-vrb scenes
(seeds 7, 11, 19) and the same scenes with each object swapped for its procedural counterpart at the
same pose, 320 x 180 RGB + depth + segmentation, 30 frames per scene and preset. Prints medians and
the load average (figures taken under load are noisy; compare ratios from one run).
"""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import dataclasses
import os
import time

import numpy as np
from shop_vrb_side_by_side import _procedural

from samplehd.render.renderer import SceneRenderer
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import compile_scene

CATALOGUES = ("procedural", "shop-vrb")


def main() -> None:
    print("load average", os.getloadavg())
    times: dict[str, list[float]] = {c: [] for c in CATALOGUES}
    for s in range(8):
        for c in CATALOGUES:
            t0 = time.perf_counter()
            sample_scene(s, 1000 + s, SceneConfig(catalogue=c))
            times[c].append(time.perf_counter() - t0)
    for c, v in times.items():
        print(f"sample_scene {c:10s} median {np.median(v):.3f} s")
    fps: dict[tuple[str, str], list[float]] = {}
    for seed in (7, 11, 19):
        shop = sample_scene(0, seed, SceneConfig(catalogue="shop-vrb", min_objects=5, max_objects=5)).scene
        old = dataclasses.replace(shop, objects=tuple(dataclasses.replace(o, instance=_procedural(o.instance))
                                                      for o in shop.objects))
        for preset in ("fast", "hd"):
            for name, scene in (("procedural", old), ("shop-vrb", shop)):
                model, data = compile_scene(scene)
                with SceneRenderer(model, 320, 180, preset) as r:
                    r.render(data, "scene", ("rgb", "depth", "segmentation"))
                    t0 = time.perf_counter()
                    for _ in range(30):
                        r.render(data, "scene", ("rgb", "depth", "segmentation"))
                    fps.setdefault((preset, name), []).append(30 / (time.perf_counter() - t0))
    for (preset, name), v in sorted(fps.items()):
        print(f"render {preset:4s} {name:10s} median {np.median(v):.1f} fps  {[round(x, 1) for x in v]}")
    print("load average", os.getloadavg())


if __name__ == "__main__":
    main()
