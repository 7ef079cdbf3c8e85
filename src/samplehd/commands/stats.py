"""Print dataset statistics (counts per family, class, colour, material; frames per episode; rejections
by reason) and write PNG bar charts and stats.json."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from rich.console import Console
from rich.table import Table

from samplehd.commands._options import check_out_dir
from samplehd.dataset.outputs import check_outputs
from samplehd.dataset.reader import DatasetReader
from samplehd.dataset.stats import dataset_stats, write_plots
from samplehd.errors import DatasetError

HELP = "print counts per family/class/colour/material, frames per episode, rejections; write PNG plots"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dir", type=Path, help="dataset directory")
    parser.add_argument("--out", type=Path, help="folder for the plots and stats.json (default: DIR/stats)")
    parser.add_argument("--no-plots", action="store_true", help="print only")


def run(args: argparse.Namespace) -> int:
    check_out_dir("--out", args.out)
    check_outputs({"--out": args.out}, {"DIR": args.dir}, in_place=args.dir)  # default: DIR/stats
    DatasetReader(args.dir).check_intact()  # no plots written into a damaged dataset
    stats = dataset_stats(args.dir)
    console = Console()
    console.print(f"[bold]{args.dir}[/bold]: {stats['scenes']} scenes, {stats['episodes']} episodes, "
                  f"{stats['frames']} frames")
    for key in ("families", "splits", "classes", "colours", "materials", "objects_per_scene"):
        t = Table(key.replace("_", " "), "count", "share")
        total = sum(stats[key].values()) or 1
        for k, v in stats[key].items():
            t.add_row(str(k), str(v), f"{v / total:.1%}")
        console.print(t)
    fpe = stats["frames_per_episode"]
    if fpe:
        console.print(f"frames per episode: min {fpe['min']}, median {fpe['median']:.0f}, mean {fpe['mean']:.1f}, "
                      f"max {fpe['max']}")
    if stats.get("disturbances"):
        t = Table("disturbance", "recovered", "absorbed", "failed", "recovery rate")
        for kind, outcomes in stats["disturbances"].items():
            rec, fail = outcomes.get("recovered", 0), outcomes.get("failed", 0)
            rate = f"{rec / (rec + fail):.1%}" if rec + fail else "-"
            t.add_row(kind, str(rec), str(outcomes.get("absorbed", 0)), str(fail), rate)
        console.print(t)
    for kind, counts in stats["rejections"].items():
        console.print(f"{kind} rejections: " + (", ".join(f"{k} {v}" for k, v in counts.items()) or "none"))
    if not args.no_plots:
        out = args.out or args.dir / "stats"
        try:
            out.mkdir(parents=True, exist_ok=True)
            paths = write_plots(stats, out)
            (out / "stats.json").write_text(json.dumps(stats, indent=1))
        except OSError as exc:
            raise DatasetError(f"{out}: cannot write plots: {exc.strerror}") from None
        console.print(f"wrote {len(paths)} plots and stats.json to {out}")
    return 0
