"""The main job on a small default: generate the tiny dataset (scenes → instructions → ground-truth
paths → images), render pictures of the world, and say where everything is."""

from __future__ import annotations

import argparse
from pathlib import Path

from samplehd.commands import generate
from samplehd.render.image_io import colorize_depth, colorize_segmentation, save_rgb
from samplehd.render.renderer import MODALITIES, SceneRenderer
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import compile_scene
from samplehd.world.seeding import scene_seed

HELP = "run the main job (tiny dataset + pictures) and say where the outputs are"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=Path, default=Path("outputs/demo"), help="output directory")
    parser.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    parser.add_argument("--seed", type=int, default=0, help="dataset seed")


def _pictures(out: Path) -> list[Path]:
    scene = sample_scene(0, scene_seed(2, 0)).scene
    model, data = compile_scene(scene)
    paths = [out / "world_hd.png", out / "world_depth.png", out / "world_segmentation.png", out / "wrist_fast.png"]
    with SceneRenderer(model, 1280, 720, "hd") as r:
        img = r.render(data, "operator", MODALITIES)
    save_rgb(paths[0], img["rgb"])
    save_rgb(paths[1], colorize_depth(img["depth"]))
    save_rgb(paths[2], colorize_segmentation(img["segmentation"]))
    with SceneRenderer(model, 640, 360, "fast") as r:
        save_rgb(paths[3], r.render(data, "wrist", ("rgb",))["rgb"])
    return paths


def run(args: argparse.Namespace) -> int:
    out: Path = args.out
    dataset = out / "dataset"
    argv = ["--preset", "tiny", "--out", str(dataset), "--seed", str(args.seed)]
    if args.workers:
        argv += ["--workers", str(args.workers)]
    if (dataset / "info.json").exists() or (dataset / "config.json").exists():
        argv.append("--resume")  # a second `make demo` finishes or reuses the first one's dataset
    parser = argparse.ArgumentParser(prog="samplehd generate")
    generate.add_arguments(parser)
    status = generate.run(parser.parse_args(argv))
    if status != 0:
        return status
    print("\nsamplehd demo: outputs in", out.resolve())
    print("  dataset:  ", dataset, " (info.json, scenes.json, instructions.json, episodes/)")
    for p in _pictures(out):
        print("  picture:  ", p)
    print(f"\nbrowse it:  .venv/bin/samplehd view {dataset}   (then open http://127.0.0.1:8000/)")
    print(f"check it:   .venv/bin/samplehd validate {dataset}")
    return 0
