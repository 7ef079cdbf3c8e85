"""Write the compiled kitchen world as MJCF, openable with ``python -m mujoco.viewer --mjcf FILE``."""

from __future__ import annotations

import argparse
from pathlib import Path

from samplehd.commands._options import check_out_file
from samplehd.scene.mjcf import export_mjcf
from samplehd.scene.world import build_world

HELP = "export the world as an MJCF file MuJoCo's viewer opens"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", required=True, type=Path, help="output .xml file")


def run(args: argparse.Namespace) -> int:
    check_out_file("--out", args.out, (".xml",))
    path = export_mjcf(build_world(), args.out)
    print(f"wrote {path}")
    return 0
