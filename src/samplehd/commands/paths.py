"""Generate ground-truth motion paths for the instructions of existing scene and instruction files:
plan, execute in physics, check success, record one frame per control step (optionally with images
rendered from the recorded states), and write one HDF5 episode file per succeeded instruction — the
same files, seed rule and work unit as ``samplehd generate`` (see :mod:`samplehd.dataset.paths`).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from samplehd.commands._options import split_names
from samplehd.dataset.paths import format_summary, generate_paths
from samplehd.dataset.render import RenderConfig
from samplehd.errors import ConfigError
from samplehd.record.paths import PathConfig
from samplehd.render.renderer import MODALITIES
from samplehd.workers import BACKENDS, Backend

HELP = "generate ground-truth motion paths (HDF5 episodes) for instructions"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenes", required=True, type=Path, help="scenes directory (with scenes.json) or file")
    parser.add_argument("--instructions", required=True, type=Path, help="instructions.json")
    parser.add_argument("--out", required=True, type=Path, help="output directory")
    parser.add_argument("--cameras", default="", help="comma-separated cameras to render per frame (none: states only)")
    parser.add_argument("--modalities", default="rgb", help=f"comma-separated: {', '.join(MODALITIES)}")
    parser.add_argument("--width", type=int, default=320, help="image width [px]")
    parser.add_argument("--height", type=int, default=180, help="image height [px]")
    parser.add_argument("--preset", default="fast", choices=["fast", "hd"], help="render quality preset")
    parser.add_argument("--workers", type=int, default=1, help="parallel worker processes")
    parser.add_argument("--backend", choices=BACKENDS, default="local", help="where work units run")
    parser.add_argument("--seed", type=int, default=0,
                        help="base seed (instruction slot k of scene i: the dataset's episode_seed(seed, i, k))")
    parser.add_argument("--limit", type=int, default=0, help="only the first N instructions (0: all)")
    parser.add_argument("--max-attempts", type=int, default=3, help="attempts per instruction before rejecting")


def run(args: argparse.Namespace) -> int:
    cameras, modalities = split_names(args.cameras), split_names(args.modalities)
    bad = [m for m in modalities if m not in MODALITIES]
    if bad or not modalities:
        raise ConfigError(f"--modalities: unknown {bad or '(none)'}; valid: {', '.join(MODALITIES)}")
    render = (RenderConfig(args.preset, args.width, args.height, cameras, modalities) if cameras
              else RenderConfig("none", args.width, args.height))
    paths = PathConfig(max_attempts=args.max_attempts)
    backend = Backend(args.backend, args.workers)

    def show(r: dict[str, Any], total: int) -> None:
        status = "ok" if r["success"] else f"rejected ({r['reason']})"
        print(f"instruction {r['instruction_index']} of {total} ({r['family']}): {status} {r['seconds']:.1f} s",
              flush=True)

    summary = generate_paths(args.scenes, args.instructions, args.out, seed=args.seed, limit=args.limit,
                             paths=paths, render=render, backend=backend, on_result=show)
    print(format_summary(summary))
    print(f"wrote {args.out / 'summary.json'}")
    return 0
