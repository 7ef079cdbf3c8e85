"""Re-render a recorded episode from its physics states (no re-simulation) to an MP4, from any camera
at any resolution; optionally also a contact sheet with one picture per subtask."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

from samplehd.commands._options import add_render_preset, check_int, check_out_file
from samplehd.dataset.container import read_episode
from samplehd.dataset.outputs import check_outputs
from samplehd.errors import ConfigError
from samplehd.fileio import check_regular_file
from samplehd.record.replay import subtask_contact_sheet
from samplehd.render.image_io import save_rgb
from samplehd.render.image_spec import PRESET_NAMES, ImageSpec
from samplehd.render.renderer import camera_names
from samplehd.render.states import render_states
from samplehd.render.video import write_mp4
from samplehd.scene.spec import SceneSpec, compile_scene
from samplehd.scene.world import CAMERA_NAMES, OPERATOR_CAMERA

if TYPE_CHECKING:
    import mujoco

HELP = "re-render a recorded episode to MP4 from its recorded states"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("episode", type=Path,
                        help="episode file (.h5) from `samplehd generate` or `samplehd paths`")
    parser.add_argument("--out", required=True, type=Path, help="output video (.mp4)")
    parser.add_argument("--camera", default=OPERATOR_CAMERA.name, help=f"camera name ({', '.join(CAMERA_NAMES)})")
    parser.add_argument("--width", type=int, default=640, help="image width [px]")
    parser.add_argument("--height", type=int, default=360, help="image height [px]")
    add_render_preset(parser, PRESET_NAMES, "fast")
    parser.add_argument("--sheet", type=Path, help="also write a per-subtask contact sheet (.png)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


# Frames rendered between two updates of the progress bar.
PROGRESS_FRAMES = 10


def run(args: argparse.Namespace) -> int:
    check_int("--width", args.width, 8, 8192)
    check_int("--height", args.height, 8, 8192)
    check_out_file("--out", args.out, (".mp4",))
    check_out_file("--sheet", args.sheet, (".png", ".jpg"))
    check_outputs({"--out": args.out, "--sheet": args.sheet}, {"EPISODE": args.episode})
    if not args.episode.exists() and not args.episode.is_symlink():
        raise ConfigError(f"{args.episode}: does not exist; give an episode file (.h5)")
    check_regular_file(args.episode, ConfigError, label=str(args.episode))
    ep = read_episode(args.episode, images="none")
    if "scene" not in ep.info:
        raise ConfigError(f"{args.episode}: the episode does not carry its scene spec (info.scene)")
    scene = SceneSpec.from_dict(ep.info["scene"])
    model, _ = compile_scene(scene, 1.0 / float(ep.info.get("physics_hz", 500.0)))
    if args.camera not in camera_names(model):
        raise ConfigError(f"--camera {args.camera!r}: unknown; valid: {', '.join(camera_names(model))}")
    rgb = _render_with_progress(model, ep.frames, ImageSpec(args.width, args.height, args.render_preset,
                                                            (args.camera,)), args.camera, args.quiet)
    write_mp4(args.out, rgb, float(ep.info.get("control_hz", 20.0)))
    print(f"wrote {args.out} ({len(rgb)} frames)")
    if args.sheet:
        save_rgb(args.sheet, subtask_contact_sheet(model, ep, ImageSpec(320, 180, args.render_preset, (args.camera,))))
        print(f"wrote {args.sheet}")
    return 0


def _render_with_progress(model: mujoco.MjModel, frames: dict[str, np.ndarray], image: ImageSpec, camera: str,
                          quiet: bool) -> np.ndarray:
    """The episode's RGB frames (T, H, W, 3), with a progress bar on stderr updated every
    :data:`PROGRESS_FRAMES` frames (none when ``quiet``)."""
    total = len(frames["qpos"])
    rgb: list[np.ndarray] = []
    with Progress(TextColumn("replay"), BarColumn(), MofNCompleteColumn(), TextColumn("frames"),
                  TimeRemainingColumn(), console=Console(stderr=True, quiet=quiet), disable=quiet) as bar:
        task = bar.add_task("frames", total=total)

        def keep(cam: str, images: dict[str, np.ndarray]) -> None:
            rgb.append(images["rgb"].copy())  # the array is reused for the next frame
            if len(rgb) % PROGRESS_FRAMES == 0 or len(rgb) == total:
                bar.update(task, completed=len(rgb))

        render_states(model, frames, image, on_frame=keep)
    return np.stack(rgb)
