"""The main job on a small default: render the world, and (when available) generate a tiny dataset."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "run the main job on a small default and say where the outputs are"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=Path, default=Path("outputs/demo"), help="output directory")


def run(args: argparse.Namespace) -> int:
    from samplehd.render.image_io import colorize_depth, colorize_segmentation, save_rgb
    from samplehd.render.renderer import SceneRenderer
    from samplehd.scene.world import compile_world

    out: Path = args.out
    model, data = compile_world()
    written = []
    with SceneRenderer(model, 1280, 720, "hd") as r:
        img = r.render(data, "operator", ("rgb", "depth", "segmentation"))
    save_rgb(out / "world_operator_hd.png", img["rgb"])
    save_rgb(out / "world_operator_depth.png", colorize_depth(img["depth"]))
    save_rgb(out / "world_operator_segmentation.png", colorize_segmentation(img["segmentation"]))
    with SceneRenderer(model, 640, 360, "fast") as r:
        save_rgb(out / "world_wrist_fast.png", r.render(data, "wrist", ("rgb",))["rgb"])
    written += ["world_operator_hd.png", "world_operator_depth.png", "world_operator_segmentation.png",
                "world_wrist_fast.png"]
    print("samplehd demo: outputs in", out.resolve())
    for name in written:
        print("  ", out / name)
    return 0
