"""A/B of physics options on dataset generation: CPU seconds and results of the same candidates.

Runs the ``sample-hd`` preset's first scenes, states only, in this process (one worker), with the
world built under one set of options, and prints CPU seconds, episodes, frames and rejections.
Compare two variants on the same ``--scenes`` and ``--seed``; run them one after the other (two at
once on two cores slow each other by about 10 %).

Usage:
    .venv/bin/python benchmarks/ab_world_options.py sleep --scenes 6 --seed 777
    .venv/bin/python benchmarks/ab_world_options.py nosleep --scenes 6 --seed 777

Variants (comma-separated): ``sleep`` (the default world), ``nosleep``, ``pyramidal`` (friction
cones), ``euler`` (integrator), ``iterN`` (solver iterations).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import mujoco

import samplehd  # noqa: F401  (picks the GL backend; the renderer works whatever the import order)
from samplehd.dataset.config import GenerateConfig, preset_config
from samplehd.dataset.generate import generate_dataset
from samplehd.scene import world
from samplehd.workers import Backend

_VALID = "sleep, nosleep, pyramidal, euler, iterN"


def _apply(spec: mujoco.MjSpec, variant: str) -> None:
    for v in filter(None, variant.split(",")):
        if v == "sleep":
            continue
        if v == "nosleep":
            spec.option.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
        elif v == "pyramidal":
            spec.option.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL
        elif v == "euler":
            spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
        elif v.startswith("iter") and v[4:].isdigit():
            spec.option.iterations = int(v[4:])
        else:
            raise SystemExit(f"ab_world_options: unknown variant {v!r}; valid: {_VALID}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("variant", help=f"comma-separated: {_VALID}")
    parser.add_argument("--scenes", type=int, default=6)
    parser.add_argument("--seed", type=int, default=777)
    args = parser.parse_args()
    _apply(mujoco.MjSpec(), args.variant)  # reject a bad variant before any work
    base_build = world.build_world

    def build(*a: Any, **k: Any) -> mujoco.MjSpec:
        spec = base_build(*a, **k)
        _apply(spec, args.variant)
        return spec

    world.build_world = build  # compile_world and the grasp-assist compile look it up at call time
    d = preset_config("sample-hd").to_dict()
    d.update(num_scenes=args.scenes, seed=args.seed, target_episodes=0)
    d["render"] = {**d["render"], "mode": "none"}
    config = GenerateConfig.from_dict(d)
    with tempfile.TemporaryDirectory() as tmp:
        c0, w0 = time.process_time(), time.perf_counter()
        s = generate_dataset(Path(tmp) / "ds", config, Backend(workers=1))
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    print(json.dumps({"variant": args.variant, "cpu_s": round(cpu, 1), "wall_s": round(wall, 1),
                      "candidates": s.candidates, "episodes": s.episodes, "frames": s.frames,
                      "rejections": s.rejections}))


if __name__ == "__main__":
    main()
