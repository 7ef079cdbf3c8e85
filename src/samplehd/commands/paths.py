"""Generate ground-truth motion paths for the instructions of existing scene and instruction files:
plan, execute in physics, check success, record one frame per control step (optionally with images
rendered from the recorded states), and write one HDF5 episode file per succeeded instruction — the
same files, seed rule and work unit as ``samplehd generate`` (see :mod:`samplehd.dataset.paths`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from samplehd.commands._options import add_render_preset, check_int, check_names, check_out_dir, split_names
from samplehd.dataset.outputs import check_outputs
from samplehd.dataset.paths import PathResult, format_summary, generate_paths
from samplehd.dataset.render import RenderConfig
from samplehd.envs.config import CAMERAS
from samplehd.record.paths import PathConfig
from samplehd.render.image_spec import PRESET_NAMES
from samplehd.render.renderer import MODALITIES
from samplehd.workers import BACKENDS, Backend

HELP = "generate ground-truth motion paths (HDF5 episodes) for instructions"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenes", required=True, type=Path, help="scenes directory (with scenes.json) or file")
    parser.add_argument("--instructions", required=True, type=Path, help="instructions.json")
    parser.add_argument("--out", required=True, type=Path, help="output directory")
    parser.add_argument("--cameras", nargs="*", default=[],
                        help="cameras to render per frame, space- or comma-separated (none: states only)")
    parser.add_argument("--modalities", nargs="+", default=["rgb"],
                        help=f"space- or comma-separated: {', '.join(MODALITIES)}")
    parser.add_argument("--width", type=int, default=320, help="image width [px]")
    parser.add_argument("--height", type=int, default=180, help="image height [px]")
    add_render_preset(parser, PRESET_NAMES, "fast")
    parser.add_argument("--workers", type=int, default=1, help="parallel worker processes")
    parser.add_argument("--backend", choices=BACKENDS, default="local", help="where work units run")
    parser.add_argument("--seed", type=int, default=0,
                        help="base seed (instruction slot k of scene i: the dataset's episode_seed(seed, i, k))")
    parser.add_argument("--limit", type=int, default=0, help="only the first N instructions (0: all)")
    parser.add_argument("--max-attempts", type=int, default=3, help="attempts per instruction before rejecting")


def run(args: argparse.Namespace) -> int:
    cameras, modalities = split_names(args.cameras, "--cameras"), split_names(args.modalities, "--modalities")
    check_names("--cameras", cameras, CAMERAS, allow_empty=True)
    check_names("--modalities", modalities, MODALITIES)
    for flag, value, lo, hi in (("--workers", args.workers, 1, None), ("--max-attempts", args.max_attempts, 1, 100),
                                ("--width", args.width, 16, 8192), ("--height", args.height, 16, 8192),
                                ("--seed", args.seed, 0, None), ("--limit", args.limit, 0, None)):
        check_int(flag, value, lo, hi)
    check_out_dir("--out", args.out, empty=True)
    check_outputs({"--out": args.out}, {"--scenes": args.scenes, "--instructions": args.instructions})
    render = (RenderConfig(args.render_preset, args.width, args.height, cameras, modalities) if cameras
              else RenderConfig("none", args.width, args.height))
    paths = PathConfig(max_attempts=args.max_attempts)
    backend = Backend(args.backend, args.workers)

    def show(r: PathResult, total: int) -> None:
        status = "ok" if r["success"] else f"rejected ({r['reason']})"
        print(f"instruction {r['instruction_index']} of {total} ({r['family']}): {status} {r['seconds']:.1f} s",
              flush=True)

    summary = generate_paths(args.scenes, args.instructions, args.out, seed=args.seed, limit=args.limit,
                             paths=paths, render=render, backend=backend, on_result=show)
    print(format_summary(summary))
    print(f"wrote {args.out / 'summary.json'}")
    return 0
