"""Sample randomised, annotated scenes: RGB, depth, segmentation and CLEVR-layout scenes.json."""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np
from PIL import Image
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

from samplehd.commands._options import add_render_preset, check_int, check_out_dir, check_out_file
from samplehd.dataset.outputs import check_outputs
from samplehd.errors import ConfigError
from samplehd.fileio import read_json
from samplehd.render.contact_sheet import contact_sheet
from samplehd.render.image_io import colorize_depth, colorize_segmentation, read_depth, read_segmentation, save_rgb
from samplehd.render.image_spec import PRESET_NAMES, ImageSpec
from samplehd.render.renderer import MODALITIES, get_preset
from samplehd.scene.config import SceneConfig
from samplehd.scene.generate import generate_scenes
from samplehd.scene.sampler import check_scene_config

HELP = "sample annotated scenes (images, depth, segmentation, scenes.json)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--num", type=int, required=True, help="number of scenes")
    parser.add_argument("--out", type=Path, required=True, help="output directory")
    parser.add_argument("--seed", type=int, default=0, help="base seed; scene i uses a stream derived from (seed, i)")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="worker processes")
    parser.add_argument("--config", type=Path, help="JSON file with a 'scene' section of sampler options")
    parser.add_argument("--width", type=int, default=640, help="image width [px]")
    parser.add_argument("--height", type=int, default=360, help="image height [px] (16:9 by default)")
    add_render_preset(parser, PRESET_NAMES, "fast", "render quality")
    parser.add_argument("--photo-look", default="fixed",
                        help="photo preset: 'fixed' look, or 'random' lights, colour temperature, textures and "
                             "exposure drawn from each scene's seed (recorded in its annotation)")
    parser.add_argument("--sheet", type=Path, help="also write a contact sheet (RGB | depth | segmentation) "
                        "of up to 16 scenes to this PNG")


# The most scenes one run makes (SAMPLE-HD has 2000).
MAX_SCENES = 1_000_000


def load_scene_config(path: Path | None):  # noqa: ANN201 - returns SceneConfig
    """Read the 'scene' section of a JSON config file (unknown keys are errors)."""
    if path is None:
        return SceneConfig()
    doc = read_json(path, ConfigError, f"--config {path}")
    if not isinstance(doc, dict):
        raise ConfigError(f"--config {path}: expected a JSON object with a 'scene' section")
    unknown = sorted(set(doc) - {"scene"})
    if unknown:
        raise ConfigError(f"--config {path}: unknown section(s) {unknown}; valid: scene")
    return SceneConfig.from_dict(doc.get("scene", {}), where=f"{path}: scene")


def write_scene_sheet(directory: Path, path: Path, count: int = 16) -> None:
    """Contact sheet of the first `count` scenes of a scenes directory: RGB | depth | segmentation."""
    scenes = json.loads((directory / "scenes.json").read_text())["scenes"][:count]
    tiles, labels = [], []
    for s in scenes:
        stem = s["image_filename"].removesuffix(".png")
        rgb = np.asarray(Image.open(directory / "images" / s["image_filename"]).convert("RGB"))
        depth = colorize_depth(read_depth(directory / "depth" / f"{stem}.npy"))
        seg = colorize_segmentation(read_segmentation(directory / "segmentation" / f"{stem}.png"))
        tiles.append(np.concatenate([rgb, depth, seg], axis=1))
        labels.append(f"{s['image_index']}: " + ", ".join(f"{o['colour']} {o['name']}" for o in s["objects"]))
    save_rgb(path, contact_sheet(tiles, columns=2, labels=labels, tile_width=840))


def run(args: argparse.Namespace) -> int:
    check_int("--num", args.num, 1, MAX_SCENES)
    check_int("--seed", args.seed, 0)
    check_int("--workers", args.workers, 1)
    check_int("--width", args.width, 16, 8192)
    check_int("--height", args.height, 16, 8192)
    check_out_dir("--out", args.out)
    if (args.out / "info.json").exists() or (args.out.is_dir() and any(args.out.iterdir())
                                              and not (args.out / "config.json").is_file()):
        raise ConfigError(f"--out {args.out}: holds other files (a dataset?); choose a new or empty folder")
    check_out_file("--sheet", args.sheet, (".png", ".jpg"))
    check_outputs({"--out": args.out, "--sheet": args.sheet}, {"--config": args.config})
    if args.photo_look != "fixed" and not get_preset(args.render_preset).path_traced:
        raise ConfigError(f"--photo-look {args.photo_look}: only used with --render-preset photo, "
                          f"not {args.render_preset!r}")
    config = load_scene_config(args.config)
    check_scene_config(config)
    console = Console(stderr=True)
    t0 = time.perf_counter()
    with Progress(TextColumn("scenes"), BarColumn(), MofNCompleteColumn(),
                  TextColumn("{task.fields[rate]:.2f}/s"), TimeRemainingColumn(), console=console,
                  disable=not console.is_terminal) as progress:
        task = progress.add_task("scenes", total=args.num, rate=0.0)

        def tick(done: int) -> None:
            progress.update(task, completed=done, rate=done / (time.perf_counter() - t0))

        image = ImageSpec(args.width, args.height, args.render_preset, modalities=MODALITIES)
        summary = generate_scenes(args.out, args.num, args.seed, config, image, args.workers, on_scene=tick,
                                  photo_look=args.photo_look)
    dt = time.perf_counter() - t0
    if args.sheet:
        write_scene_sheet(args.out, args.sheet)
        print(f"wrote {args.sheet}")
    print(f"wrote {args.num} scenes to {args.out} in {dt:.1f} s ({args.num / dt:.2f} scenes/s); "
          f"rejections: {summary['rejections']}")
    return 0
