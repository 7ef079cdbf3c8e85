"""Render (or re-render) every episode of a dataset from its stored physics states: set qpos, qvel and
act, mj_forward, render; no re-simulation. Replaces all images, or with --add keeps the other cameras
(each camera has its own resolution and preset). Parallel; run it again to resume after an interruption."""

from __future__ import annotations

import argparse
from pathlib import Path

from samplehd.commands._options import add_render_preset, split_names
from samplehd.dataset.progress import RichProgress
from samplehd.dataset.render import RenderConfig, check_render_applies
from samplehd.dataset.rerender import rerender_dataset
from samplehd.render.image_spec import PRESET_NAMES
from samplehd.render.renderer import MODALITIES
from samplehd.workers import BACKENDS, Backend, default_workers

HELP = "add or replace the images of every episode from the stored states (no re-simulation)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dir", type=Path, help="dataset directory")
    parser.add_argument("--cameras", nargs="+", default=["scene"], help="cameras (scene, operator, wrist)")
    parser.add_argument("--width", type=int, default=320, help="image width [px]")
    parser.add_argument("--height", type=int, default=180, help="image height [px]")
    parser.add_argument("--modalities", nargs="+", default=list(MODALITIES),
                        help="rgb depth segmentation")
    add_render_preset(parser, PRESET_NAMES, "fast", "render quality")
    parser.add_argument("--every", type=int, default=1,
                        help="images at every N-th frame only (keyframes; 0: only --subtask-ends); the dataset "
                             "records which frames of each camera have images")
    parser.add_argument("--subtask-ends", action="store_true",
                        help="also render the first and last frame of each subtask")
    parser.add_argument("--photo-look", default="fixed",
                        help="photo preset: 'fixed', or 'random' lights, textures and exposure drawn from each "
                             "scene's seed")
    parser.add_argument("--add", action="store_true",
                        help="keep the episodes' other cameras and modalities (a camera + modality rendered "
                             "again is overwritten); default: replace all images")
    parser.add_argument("--workers", type=int, default=default_workers(), help="worker processes")
    parser.add_argument("--backend", choices=BACKENDS, default="local", help="where work units run")
    parser.add_argument("--ray-address", help="Ray cluster address (default: start a local Ray)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")


def run(args: argparse.Namespace) -> int:
    render = RenderConfig.from_dict({"mode": args.render_preset, "width": args.width, "height": args.height,
                                     "cameras": split_names(args.cameras, "--cameras"),
                                     "modalities": split_names(args.modalities, "--modalities"),
                                     "every": args.every, "subtask_ends": args.subtask_ends, "look": args.photo_look},
                                    where="command line")
    check_render_applies(render, {"look": "--photo-look"} if args.photo_look != "fixed" else {})
    backend = Backend(args.backend, args.workers, args.ray_address)
    backend.connect()  # before anything is written
    with RichProgress(disable=args.quiet) as progress:
        res = rerender_dataset(args.dir, render, backend, progress, add=args.add)
    verb = "added images to" if args.add else "rerendered"
    rate = res["frames"] / max(res["seconds"], 1e-9)
    print(f"{verb} {res['rendered']} episodes ({res['skipped']} already done), {res['frames']} frames in "
          f"{res['seconds']:.1f} s ({rate:.1f} frames/s)")
    return 0
