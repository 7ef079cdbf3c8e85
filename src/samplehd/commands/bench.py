"""Measure performance: physics, control, IK, rendering, language, scenes, episodes, datasets.

Prints a table of medians and writes ``bench.json`` to --out. Figures are for reports, never tests.
"""

from __future__ import annotations

import argparse
import importlib
import json
import pkgutil
from pathlib import Path

HELP = "run the performance benchmarks and print/write the figures"


def _areas() -> list[str]:
    from samplehd import bench

    return [m.name for m in pkgutil.iter_modules(bench.__path__) if not m.name.startswith("_")]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--only", nargs="+", metavar="AREA", help=f"areas to run (default: all of {_areas()})")
    parser.add_argument("--repeats", type=int, default=3, help="repeats per figure (the median is reported)")
    parser.add_argument("--out", type=Path, default=Path("outputs/bench"), help="directory for bench.json")


def run(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.table import Table

    from samplehd.errors import ConfigError

    areas = _areas()
    chosen = args.only or areas
    unknown = [a for a in chosen if a not in areas]
    if unknown:
        raise ConfigError(f"--only: unknown areas {unknown}; valid: {', '.join(areas)}")
    if args.repeats < 1:
        raise ConfigError(f"--repeats {args.repeats}: must be an integer ≥ 1")
    from samplehd.commands._options import check_out_dir

    check_out_dir("--out", args.out)
    console = Console()
    figures = []
    for area in chosen:
        console.print(f"[bold]bench {area}[/bold] ...")
        module = importlib.import_module(f"samplehd.bench.{area}")
        figures.extend(module.run(repeats=args.repeats))
    table = Table("area", "figure", "median", "unit", "note")
    for f in figures:
        table.add_row(f.area, f.name, f"{f.value:,.3g}" if f.value < 100 else f"{f.value:,.0f}", f.unit, f.note)
    console.print(table)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench.json").write_text(json.dumps([f.to_dict() for f in figures], indent=2))
    console.print(f"wrote {args.out / 'bench.json'}")
    return 0
