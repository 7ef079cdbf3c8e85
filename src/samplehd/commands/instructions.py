"""Generate language instructions with programs for the scenes of a scenes file (CLEVR layout).

Templates are drawn so that templates (or families) come out near uniform; each instruction gets
the shortest unique descriptions of its objects, a CLEVR node-list program, a SAMPLE-HD flat
program and the task both evaluate to. Output: instructions.json in CLEVR's question-file layout.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

from samplehd.commands._options import check_int, check_names, check_out_file, split_names
from samplehd.dataset.outputs import check_outputs
from samplehd.errors import ConfigError
from samplehd.language.instruction_file import generate_instruction_file, parse_split_ratio, write_instructions
from samplehd.language.scene import load_scenes
from samplehd.language.templates import load_templates
from samplehd.tasks.task import family_names
from samplehd.world.reach import make_reachable

HELP = "generate instructions (text, programs, tasks) for a scenes file"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenes", required=True, type=Path, help="scenes.json, or a folder holding it")
    parser.add_argument("--out", required=True, type=Path, help="instructions.json to write")
    parser.add_argument("--per-scene", type=int, default=5, help="instructions per scene (fewer if impossible)")
    parser.add_argument(
        "--balance", choices=["templates", "families"], default="templates", help="what comes out uniform"
    )
    parser.add_argument(
        "--families",
        nargs="+",
        metavar="FAMILY",
        help="only these families, e.g. place stack put remove pick_up place_relative stack_three; all when omitted",
    )
    parser.add_argument(
        "--templates",
        action="append",
        type=Path,
        metavar="FILE_OR_DIR",
        help="extra template file or folder of *.json templates (repeatable)",
    )
    parser.add_argument("--no-default-templates", action="store_true", help="use only --templates")
    parser.add_argument(
        "--reach",
        choices=["annulus", "ik"],
        default="annulus",
        help="reachability test: the layout's reach annulus, or annulus + analytic UR5e IK (slower)",
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed")
    parser.add_argument(
        "--split-ratio", metavar="NAME=FRAC,...", help="reassign scene splits, e.g. train=0.95,test=0.05"
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar or summary")


def run(args: argparse.Namespace) -> int:
    check_int("--per-scene", args.per_scene, 1, 99)
    check_int("--seed", args.seed, 0)
    given = args.families is not None
    args.families = split_names(args.families, "--families") or None
    if given and args.families is None:  # `--families ""` or `--families ,`: not "all families"
        raise ConfigError(f"--families: names no family; give at least one of {', '.join(family_names())}, or "
                          f"leave it out for all")
    check_names("--families", args.families, family_names())
    check_out_file("--out", args.out, (".json",))
    scenes_file = args.scenes / "scenes.json" if args.scenes.is_dir() else args.scenes
    check_outputs({"--out": args.out},
                  {"--scenes": scenes_file, **{f"--templates {t}": t for t in args.templates or []}})
    if args.no_default_templates and not args.templates:
        raise ConfigError("--no-default-templates needs at least one --templates FILE_OR_DIR")
    templates = load_templates(args.templates or [], include_default=not args.no_default_templates)
    ratio = parse_split_ratio(args.split_ratio) if args.split_ratio else None
    info, scenes = load_scenes(args.scenes)
    console = Console(stderr=True, quiet=args.quiet)
    columns = (
        TextColumn("instructions"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("scenes"),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=console, disable=args.quiet) as progress:
        bar = progress.add_task("instructions", total=len(scenes))
        document = generate_instruction_file(
            scenes,
            args.seed,
            per_scene=args.per_scene,
            balance=args.balance,
            families=args.families,
            templates=templates,
            split_ratio=ratio,
            reachable=make_reachable(args.reach),
            scenes_info=info,
            progress=lambda done, total: progress.update(bar, completed=done),
            source=str(args.scenes),
        )
    path = write_instructions(args.out, document)
    if not args.quiet:
        meta = document["info"]
        counts = ", ".join(f"{k} {v}" for k, v in meta["counts"]["families"].items())
        top = sorted(meta["rejections"].items(), key=lambda kv: -kv[1])[:6]
        console.print(f"{len(document['instructions'])} instructions for {meta['scenes']} scenes: {counts}")
        console.print("rejections: " + ", ".join(f"{k} {v}" for k, v in top))
        print(f"wrote {path}")
    return 0
