"""The main job on a small default: generate the tiny dataset (scenes → instructions → ground-truth
paths → images), render pictures of the world, and say where everything is."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from samplehd.commands import generate
from samplehd.commands._options import check_int, check_out_dir
from samplehd.dataset.outputs import check_outputs
from samplehd.errors import RenderError
from samplehd.render.image_io import colorize_depth, colorize_segmentation, save_rgb
from samplehd.render.renderer import MODALITIES, SceneRenderer
from samplehd.robot.constants import WRIST_CAMERA
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import compile_scene
from samplehd.scene.world import OPERATOR_CAMERA
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
        img = r.render(data, OPERATOR_CAMERA.name, MODALITIES)
    save_rgb(paths[0], img["rgb"])
    save_rgb(paths[1], colorize_depth(img["depth"]))
    save_rgb(paths[2], colorize_segmentation(img["segmentation"]))
    with SceneRenderer(model, 640, 360, "fast") as r:
        save_rgb(paths[3], r.render(data, WRIST_CAMERA, ("rgb",))["rgb"])
    return paths + _photo_picture(out, model, data)


def _photo_picture(out: Path, model: object, data: object) -> list[Path]:
    """The same view path traced (the photo preset); one line saying what to install where it cannot run."""
    path = out / "world_photo.png"
    try:
        with SceneRenderer(model, 1280, 720, "photo") as r:
            save_rgb(path, r.render(data, OPERATOR_CAMERA.name, ("rgb",))["rgb"])
    except RenderError as exc:
        print(f"samplehd demo: no photo picture: {exc}")
        return []
    return [path]


def run(args: argparse.Namespace) -> int:

    check_int("--workers", args.workers, 1)
    check_int("--seed", args.seed, 0)
    check_out_dir("--out", args.out)
    check_outputs({"--out": args.out}, in_place=args.out / "dataset")
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
    prog = _program()
    print(f"\nbrowse it:  {prog} view {dataset}   (then open http://127.0.0.1:8000/)")
    print(f"check it:   {prog} validate {dataset}")
    return 0


def _program() -> str:
    """How to run samplehd from the user's shell: ``samplehd`` where that is this installation's
    command on PATH, else this Python with ``-m samplehd``."""
    import shutil

    found = shutil.which("samplehd")
    if found and Path(found).parent == Path(sys.executable).parent:
        return "samplehd"
    return f"{sys.executable} -m samplehd"
