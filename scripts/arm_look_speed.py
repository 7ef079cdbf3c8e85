"""The arm's ``mesh`` and ``primitive`` looks side by side in one run: world compile time and render frame rates.

    python scripts/arm_look_speed.py [--rounds 5] [--frames 20]

The kitchen world with the arm at home, 320 x 180, from the ``operator`` and ``wrist`` cameras, RGB alone
and RGB + depth + segmentation, presets fast and hd; the looks alternate round by round. Prints medians of
wall-clock frames/s and of CPU milliseconds per frame (the process's CPU time, llvmpipe's threads included:
steadier than wall time on a loaded machine), and the load average.
"""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import argparse
import os
import time

import numpy as np

from samplehd.render.renderer import MODALITIES, SceneRenderer
from samplehd.robot.constants import ROBOT_LOOKS
from samplehd.scene.world import WorldConfig, compile_world


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--frames", type=int, default=20)
    args = ap.parse_args()
    print("load average", os.getloadavg())
    worlds = {look: compile_world(config=WorldConfig(robot_look=look)) for look in ROBOT_LOOKS}
    compile_s: dict[str, list[float]] = {look: [] for look in ROBOT_LOOKS}
    fps: dict[tuple[str, str, str, str], list[float]] = {}
    cpu_ms: dict[tuple[str, str, str, str], list[float]] = {}
    for _ in range(args.rounds):
        for look in ROBOT_LOOKS:
            t0 = time.process_time()
            compile_world(config=WorldConfig(robot_look=look))
            compile_s[look].append(time.process_time() - t0)
        for preset in ("fast", "hd"):
            for look in ROBOT_LOOKS:
                model, data = worlds[look]
                with SceneRenderer(model, 320, 180, preset) as r:
                    for camera in ("operator", "wrist"):
                        for mods in (("rgb",), MODALITIES):
                            r.render(data, camera, mods)
                            t0, c0 = time.perf_counter(), time.process_time()
                            for _ in range(args.frames):
                                r.render(data, camera, mods)
                            key = (preset, camera, "+".join(mods), look)
                            fps.setdefault(key, []).append(args.frames / (time.perf_counter() - t0))
                            cpu_ms.setdefault(key, []).append(1000 * (time.process_time() - c0) / args.frames)
    for look, v in compile_s.items():
        print(f"compile_world {look:9s} median {1000 * np.median(v):.0f} ms CPU")
    for preset, camera, mods, look in sorted(fps):
        if look != ROBOT_LOOKS[0]:
            continue
        mesh, prim = (np.median(fps[preset, camera, mods, k]) for k in ("mesh", "primitive"))
        cmesh, cprim = (np.median(cpu_ms[preset, camera, mods, k]) for k in ("mesh", "primitive"))
        print(f"render {preset:4s} {camera:8s} {mods:24s} fps primitive {prim:6.1f} mesh {mesh:6.1f} "
              f"({mesh / prim:.2f})  CPU ms/frame primitive {cprim:6.1f} mesh {cmesh:6.1f} ({cmesh / cprim:.2f})")
    print("load average", os.getloadavg())


if __name__ == "__main__":
    main()
