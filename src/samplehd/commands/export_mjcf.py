"""Write the kitchen world as MJCF, openable with ``python -m mujoco.viewer --mjcf FILE``: the empty
world (table and robot), a scene file's scene, or a dataset episode's scene, with keyframes."""

from __future__ import annotations

import argparse
from pathlib import Path

from samplehd.commands._options import check_out_file
from samplehd.dataset.outputs import check_outputs
from samplehd.errors import ConfigError
from samplehd.export.mjcf import scene_mjcf_from_dataset, scene_mjcf_from_file
from samplehd.scene.mjcf import export_mjcf
from samplehd.scene.world import build_world

HELP = "export the world, a scene or a dataset episode's scene as an MJCF file MuJoCo's viewer opens"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", required=True, type=Path, help="output .xml file")
    parser.add_argument("--scene", type=Path, help="scene file (scenes/SHD_<split>_<index>.json of a dataset)")
    parser.add_argument("--dataset", type=Path, help="samplehd dataset (with --episode)")
    parser.add_argument("--episode", type=int, help="episode index of --dataset (keyframes home and final)")


def run(args: argparse.Namespace) -> int:
    check_out_file("--out", args.out, (".xml",))
    check_outputs({"--out": args.out}, {"--scene": args.scene, "--dataset": args.dataset})
    if (args.dataset is None) != (args.episode is None):
        raise ConfigError("--dataset and --episode go together: --dataset DIR --episode I")
    if args.scene is not None and args.dataset is not None:
        raise ConfigError("--scene FILE and --dataset DIR --episode I exclude each other; give one")
    if args.dataset is not None:
        path = scene_mjcf_from_dataset(args.dataset, args.episode, args.out)
    elif args.scene is not None:
        path = scene_mjcf_from_file(args.scene, args.out)
    else:
        path = export_mjcf(build_world(), args.out)
    print(f"wrote {path}; open it with: python -m mujoco.viewer --mjcf {path}")
    return 0
