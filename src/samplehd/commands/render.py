"""Render the kitchen world (or one scene of a scenes file) from a named camera to image files."""

from __future__ import annotations

import argparse
from pathlib import Path

from samplehd.commands._options import add_render_preset, check_int, check_out_file
from samplehd.dataset.outputs import check_outputs
from samplehd.render.image_io import colorize_depth, colorize_segmentation, save_depth, save_rgb, save_segmentation
from samplehd.render.image_spec import PRESET_NAMES, ImageSpec
from samplehd.scene.world import OPERATOR_CAMERA, compile_world

HELP = "render RGB (and optionally depth / segmentation) from a named camera"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--camera", default=OPERATOR_CAMERA.name, help="camera name (operator, wrist, ...)")
    parser.add_argument("--width", type=int, default=640, help="image width [px]")
    parser.add_argument("--height", type=int, default=360, help="image height [px]")
    add_render_preset(parser, PRESET_NAMES, "hd")
    parser.add_argument("--out", required=True, type=Path, help="RGB output file (.png)")
    parser.add_argument("--depth", type=Path, help="depth output: .png (uint16 mm) or .npy (float32 m)")
    parser.add_argument("--segmentation", type=Path, help="instance-id PNG output")
    parser.add_argument("--preview", action="store_true", help="also write false-colour depth/seg previews")


def run(args: argparse.Namespace) -> int:
    check_int("--width", args.width, 8, 8192)
    check_int("--height", args.height, 8, 8192)
    # Every output is checked before the first is written.
    check_out_file("--out", args.out, (".png", ".jpg", ".jpeg"))
    check_out_file("--depth", args.depth, (".png", ".npy"))
    check_out_file("--segmentation", args.segmentation, (".png",))
    previews = ({"--preview (depth)": args.depth.with_name(args.depth.stem + "_preview.png") if args.depth else None,
                 "--preview (segmentation)": args.segmentation.with_name(args.segmentation.stem + "_preview.png")
                 if args.segmentation else None} if args.preview else {})
    check_outputs({"--out": args.out, "--depth": args.depth, "--segmentation": args.segmentation, **previews})
    model, data = compile_world()
    modalities = ["rgb"]
    if args.depth:
        modalities.append("depth")
    if args.segmentation:
        modalities.append("segmentation")
    image = ImageSpec(args.width, args.height, args.render_preset, (args.camera,), modalities)
    with image.renderer(model) as renderer:
        images = renderer.render(data, args.camera, image.modalities)
    save_rgb(args.out, images["rgb"])
    print(f"wrote {args.out}")
    if args.depth:
        save_depth(args.depth, images["depth"])
        print(f"wrote {args.depth}")
        if args.preview:
            save_rgb(args.depth.with_name(args.depth.stem + "_preview.png"), colorize_depth(images["depth"]))
    if args.segmentation:
        save_segmentation(args.segmentation, images["segmentation"])
        print(f"wrote {args.segmentation}")
        if args.preview:
            p = args.segmentation.with_name(args.segmentation.stem + "_preview.png")
            save_rgb(p, colorize_segmentation(images["segmentation"]))
    return 0
