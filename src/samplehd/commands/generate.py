"""Generate a dataset: scenes → instructions → ground-truth paths → images, resumable and parallel.

Presets: tiny (4 scenes, ~8 candidates, 128×72 images, about a minute on 2 cores), small (40 scenes,
320×180), sample-hd (2000 scenes of 3–5 objects, stop at 8360 successful instructions, 640×360,
several moved objects picked nearest the arm first: paths.planner.order nearest, SAMPLE-HD's order).
A --config JSON file overrides the preset; flags override both. The same config and seed give the
same dataset whatever --workers or --backend; --resume finishes an interrupted run.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from samplehd.commands._options import split_names
from samplehd.dataset.config import PRESETS, GenerateConfig, load_config, preset_config
from samplehd.dataset.generate import GenerateSummary, generate_dataset
from samplehd.dataset.layout import INFO_FILE
from samplehd.dataset.outputs import check_outputs
from samplehd.dataset.progress import RichProgress
from samplehd.dataset.render import RENDER_MODES, check_render_applies
from samplehd.errors import SamplehdError
from samplehd.fileio import read_json
from samplehd.workers import BACKENDS, Backend, default_workers

HELP = "generate a dataset (scenes, instructions, paths, images) with resume, local workers or Ray"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--preset", choices=list(PRESETS), default="tiny", help="base configuration")
    parser.add_argument("--out", type=Path, required=True, help="dataset directory")
    parser.add_argument("--config", type=Path, help="JSON config overriding the preset (see docs/FORMAT.md)")
    parser.add_argument("--workers", type=int, default=default_workers(), help="worker processes (local backend)")
    parser.add_argument("--backend", choices=BACKENDS, default="local", help="where work units run")
    parser.add_argument("--ray-address", help="Ray cluster address (default: start a local Ray)")
    parser.add_argument("--render", choices=RENDER_MODES, help="images per episode: none (states only), fast, hd, "
                        "photo (path traced)")
    parser.add_argument("--width", type=int, help="image width [px]")
    parser.add_argument("--height", type=int, help="image height [px]")
    parser.add_argument("--cameras", nargs="+", help="cameras to render (scene, operator, wrist)")
    parser.add_argument("--modalities", nargs="+", help="rgb depth segmentation")
    parser.add_argument("--scenes", type=int, help="number of scenes (overrides the preset)")
    parser.add_argument("--families", nargs="+", help="task families of the instructions, e.g. pick_up place "
                        "(instructions.families; all when omitted)")
    parser.add_argument("--target", type=int, help="stop at this many successful episodes (0: no target)")
    parser.add_argument("--seed", type=int, help="base seed")
    parser.add_argument("--disturb", type=float, metavar="P", help="chance per episode of one disturbance the "
                        "oracle recovers from (disturbances.probability; 0: none)")
    parser.add_argument("--disturb-kinds", nargs="+", metavar="KIND", help="disturbance kinds drawn from: "
                        "missed_grasp slip nudge wrong_object short_release (default: all)")
    parser.add_argument("--resume", action="store_true", help="finish the dataset already in --out")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")


def resolve_config(args: argparse.Namespace):  # noqa: ANN201 - GenerateConfig
    """Preset, then --config file, then flags; a bad flag's message names the flag."""
    config = load_config(args.config, preset_config(args.preset))
    flags: list[tuple[str, dict]] = []
    for flag, key in (("seed", "seed"), ("scenes", "num_scenes"), ("target", "target_episodes")):
        if getattr(args, flag) is not None:
            flags.append((f"--{flag}", {key: getattr(args, flag)}))
    for flag, key in (("render", "mode"), ("width", "width"), ("height", "height")):
        if getattr(args, flag) is not None:
            flags.append((f"--{flag}", {"render": {key: getattr(args, flag)}}))
    for flag in ("cameras", "modalities"):
        names = getattr(args, flag)
        if names is not None:
            flags.append((f"--{flag}", {"render": {flag: list(split_names(names, f"--{flag}"))}}))
    if args.disturb is not None:
        flags.append(("--disturb", {"disturbances": {"probability": args.disturb}}))
    if args.disturb_kinds is not None:
        flags.append(("--disturb-kinds", {"disturbances": {"kinds": list(split_names(args.disturb_kinds,
                                                                                      "--disturb-kinds"))}}))
    if args.families is not None:
        flags.append(("--families", {"instructions": {"families": list(split_names(args.families, "--families"))}}))
    for flag, top in flags:
        config = GenerateConfig.from_dict(top, where=flag, base=config)
    check_render_applies(config.render, {next(iter(top["render"])): flag for flag, top in flags if "render" in top})
    return config


def run(args: argparse.Namespace) -> int:
    check_outputs({"--out": args.out}, {"--config": args.config}, in_place=args.out)
    config = resolve_config(args)
    backend = Backend(args.backend, args.workers, args.ray_address)
    backend.connect()  # before anything is written
    was_complete = args.resume and _is_complete(args.out)
    with RichProgress(disable=args.quiet) as progress:
        progress.note(f"generating into {args.out} ({backend.describe()}, render {config.render.mode}"
                      f"{'' if not config.render.enabled else f' {config.render.width}x{config.render.height}'})")
        summary = generate_dataset(args.out, config, backend, resume=args.resume, progress=progress)
    if was_complete and summary.units_run == 0:
        print(f"nothing to do: the dataset {args.out} is complete ({summary.episodes} episodes)")
        return 0
    print_summary(args.out, summary, config)
    return 0


def _is_complete(out: Path) -> bool:
    """Whether ``out`` holds a dataset whose generation has finished (its ``info.json`` says so)."""
    try:
        return read_json(out / INFO_FILE).get("status") == "complete"
    except (SamplehdError, AttributeError):
        return False


def print_summary(out: Path, summary: GenerateSummary, config: Any) -> None:
    """The final summary of a run, on stdout."""
    console = Console()
    t = Table(title=f"dataset {out}", show_header=False)
    t.add_row("scenes", str(summary.scenes))
    t.add_row("instruction candidates", f"{summary.candidates} ({summary.attempted} attempted)")
    rate = summary.episodes / max(summary.attempted, 1)
    t.add_row("episodes", f"{summary.episodes} ({rate:.0%} of attempted paths succeeded)")
    if config.target_episodes:
        t.add_row("target", f"{config.target_episodes} ({'reached' if summary.target_reached else 'NOT reached'})")
    t.add_row("families", ", ".join(f"{k} {v}" for k, v in summary.families.items()))
    t.add_row("frames", f"{summary.frames} ({summary.frames / max(summary.episodes, 1):.0f} per episode)")
    t.add_row("path rejections", ", ".join(f"{k} {v}" for k, v in summary.rejections.items()) or "none")
    t.add_row("scene rejections", ", ".join(f"{k} {v}" for k, v in summary.scene_rejections.items()) or "none")
    t.add_row("wall time", f"{summary.seconds:.1f} s ({summary.units_run} path units run, "
                           f"{summary.frames / max(summary.seconds, 1e-9):.0f} frames/s overall)")
    console.print(t)
    if not summary.target_reached:
        console.print(f"[yellow]only {summary.episodes} of the target {config.target_episodes} episodes: "
                      f"raise instructions.per_scene or num_scenes[/yellow]")
