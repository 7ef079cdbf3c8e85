"""A/B of physics options on dataset generation: CPU seconds and results of the same candidates.

``samplehd bench world-options VARIANT`` runs the ``sample-hd`` preset's first scenes, states only, in
this process (one worker), with the world built under one set of options, and prints CPU seconds,
episodes, frames and rejections as one JSON line. Compare two variants on the same ``--scenes`` and
``--seed``, one after the other (two at once on two cores slow each other by about 10 %)::

    samplehd bench world-options sleep --scenes 6 --seed 777
    samplehd bench world-options nosleep --scenes 6 --seed 777

Variants (comma-separated): ``sleep`` (the default world), ``nosleep``, ``pyramidal`` (friction
cones), ``euler`` (integrator), ``iterN`` (solver iterations). No figures for the ``samplehd bench``
table: this area only has its report.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import mujoco

from samplehd.dataset.config import GenerateConfig, preset_config
from samplehd.dataset.generate import generate_dataset
from samplehd.errors import ConfigError
from samplehd.scene import world
from samplehd.workers import Backend

__all__ = ["add_arguments", "apply_variant", "report"]

_VALID = "sleep, nosleep, pyramidal, euler, iterN"


def apply_variant(spec: mujoco.MjSpec, variant: str) -> None:
    """Set the physics options named by ``variant`` on a world spec.

    Raises:
        ConfigError: an unknown variant (the message lists the valid ones).
    """
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
            raise ConfigError(f"variant {v!r}: unknown; valid: {_VALID}")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("variant", help=f"comma-separated: {_VALID}")
    parser.add_argument("--scenes", type=int, default=6, help="scenes of the sample-hd preset to run")
    parser.add_argument("--seed", type=int, default=777, help="base seed")


def report(args: argparse.Namespace) -> int:
    """Generate the scenes' paths under the variant; print one JSON line of CPU time and results."""
    apply_variant(mujoco.MjSpec(), args.variant)  # reject a bad variant before any work
    base_build = world.build_world

    def build(*a: Any, **k: Any) -> mujoco.MjSpec:
        spec = base_build(*a, **k)
        apply_variant(spec, args.variant)
        return spec

    d = preset_config("sample-hd").to_dict()
    d.update(num_scenes=args.scenes, seed=args.seed, target_episodes=0)
    d["render"] = {**d["render"], "mode": "none"}
    config = GenerateConfig.from_dict(d)
    world.build_world = build  # compile_world and the grasp-assist compile look it up at call time
    try:
        with tempfile.TemporaryDirectory() as tmp:
            c0, w0 = time.process_time(), time.perf_counter()
            s = generate_dataset(Path(tmp) / "ds", config, Backend(workers=1))
            cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    finally:
        world.build_world = base_build
    print(json.dumps({"variant": args.variant, "cpu_s": round(cpu, 1), "wall_s": round(wall, 1),
                      "candidates": s.candidates, "episodes": s.episodes, "frames": s.frames,
                      "rejections": s.rejections}))
    return 0
