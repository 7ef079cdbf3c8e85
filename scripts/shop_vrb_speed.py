"""Procedural vs shop-vrb side by side in one run: scene sampling time, render frame rates and path frames/s.

    python scripts/shop_vrb_speed.py [--presets fast hd photo] [--frames 30] [--photo-frames 3] [--paths]

Scene sampling: seeds 1000..1007 with each catalogue, interleaved. Rendering: three shop-vrb scenes
(seeds 7, 11, 19) and the same scenes with each object swapped for its procedural counterpart at the
same pose, 320 x 180 RGB + depth + segmentation, ``--frames`` frames per scene and preset (``photo``:
``--photo-frames``, after one warm-up frame). ``--paths``: the oracle picks up each object of those
scenes (state only, no images), episode frames per second of wall and of CPU time. Prints medians (render:
per wall and per CPU second, llvmpipe's threads included, steadier on a loaded machine) and the
load average (figures taken under load are noisy; compare ratios from one run).
"""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import argparse
import dataclasses
import os
import time

import numpy as np
from shop_vrb_side_by_side import _procedural

from samplehd.motion.assist import compile_scene_with_assist
from samplehd.record.paths import PathRejected, plan_and_execute
from samplehd.render.renderer import SceneRenderer
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import SceneSpec, compile_scene

CATALOGUES = ("procedural", "shop-vrb")
SEEDS = (7, 11, 19)


def _twins(seed: int) -> dict[str, SceneSpec]:
    """A shop-vrb scene and the same scene with procedural objects at the same poses."""
    shop = sample_scene(0, seed, SceneConfig(catalogue="shop-vrb", min_objects=5, max_objects=5)).scene
    old = dataclasses.replace(shop, objects=tuple(dataclasses.replace(o, instance=_procedural(o.instance))
                                                  for o in shop.objects))
    return {"procedural": old, "shop-vrb": shop}


def _path_rates(scene: SceneSpec) -> tuple[int, float, float]:
    """Frames, wall seconds and CPU seconds of picking up each object the oracle can pick up."""
    frames, wall, cpu = 0, 0.0, 0.0
    for i in range(len(scene.objects)):
        compiled = compile_scene_with_assist(scene)
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            ep = plan_and_execute(scene, {"type": "pick_up", "objects": [i]}, np.random.default_rng(i),
                                  compiled=compiled)
        except PathRejected:
            continue
        wall += time.perf_counter() - t0
        cpu += time.process_time() - c0
        frames += ep.num_frames
    return frames, wall, cpu


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--presets", nargs="+", default=["fast", "hd"], choices=["fast", "hd", "photo"])
    p.add_argument("--frames", type=int, default=30, help="frames per scene and preset (fast, hd)")
    p.add_argument("--photo-frames", type=int, default=3, help="frames per scene with photo")
    p.add_argument("--paths", action="store_true", help="also the oracle's pick-up paths, frames/s")
    p.add_argument("--no-sampling", action="store_true", help="skip the scene sampling times")
    a = p.parse_args()
    print("load average", os.getloadavg())
    if not a.no_sampling:
        times: dict[str, list[float]] = {c: [] for c in CATALOGUES}
        for s in range(8):
            for c in CATALOGUES:
                t0 = time.perf_counter()
                sample_scene(s, 1000 + s, SceneConfig(catalogue=c))
                times[c].append(time.perf_counter() - t0)
        for c, v in times.items():
            print(f"sample_scene {c:10s} median {np.median(v):.3f} s")
    fps: dict[tuple[str, str], list[float]] = {}
    cpu: dict[tuple[str, str], list[float]] = {}  # frames per CPU second (llvmpipe's threads included)
    paths: dict[str, list[tuple[int, float, float]]] = {c: [] for c in CATALOGUES}
    for seed in SEEDS:
        twins = _twins(seed)
        for preset in a.presets:
            n = a.photo_frames if preset == "photo" else a.frames
            for name, scene in twins.items():
                model, data = compile_scene(scene)
                with SceneRenderer(model, 320, 180, preset) as r:
                    r.render(data, "scene", ("rgb", "depth", "segmentation"))
                    t0, c0 = time.perf_counter(), time.process_time()
                    for _ in range(n):
                        r.render(data, "scene", ("rgb", "depth", "segmentation"))
                    fps.setdefault((preset, name), []).append(n / (time.perf_counter() - t0))
                    cpu.setdefault((preset, name), []).append(n / (time.process_time() - c0))
        if a.paths:
            for name, scene in twins.items():
                paths[name].append(_path_rates(scene))
    for (preset, name), v in sorted(fps.items()):
        print(f"render {preset:5s} {name:10s} median {np.median(v):6.2f} fps  {[round(x, 2) for x in v]}  "
              f"{np.median(cpu[preset, name]):6.2f} frames/CPU-s  {[round(x, 2) for x in cpu[preset, name]]}")
    for name, runs in paths.items():
        if runs:
            f, w, c = (sum(r[k] for r in runs) for k in range(3))
            print(f"paths {name:10s} {f} frames: {f / w:.0f} frames/s, {f / c:.0f} frames/CPU-s "
                  f"(per scene {[round(r[0] / r[1]) for r in runs if r[1]]})")
    print("load average", os.getloadavg())


if __name__ == "__main__":
    main()
