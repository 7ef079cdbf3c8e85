"""Measure performance: physics, control, IK, rendering, language, scenes, episodes, datasets.

``samplehd bench`` prints a table of medians of every area's figures and writes ``bench.json`` to
--out (``--only`` picks areas). ``samplehd bench AREA ...`` prints that area's detailed report, e.g.
``samplehd bench paths oracle --scenes 70 --seed 130000``, ``samplehd bench dataset --project DIR``,
``samplehd bench env --robosuite-python PY`` or ``samplehd bench world-options nosleep``.
``samplehd bench --report`` measures the performance table of docs/PERFORMANCE.md in one run and writes
it between its markers (see :mod:`samplehd.bench._table`).
Figures are for reports, never tests. The code of every area lives in :mod:`samplehd.bench`.
"""

from __future__ import annotations

import argparse
import importlib
import json
import pkgutil
from pathlib import Path
from types import ModuleType

from rich.console import Console
from rich.table import Table

from samplehd import bench
from samplehd.bench import _table
from samplehd.commands._options import check_out_dir, sigterm_as_interrupt
from samplehd.dataset.outputs import check_outputs
from samplehd.errors import ConfigError

HELP = "run the performance benchmarks and print/write the figures"


def _modules() -> dict[str, ModuleType]:
    names = [m.name for m in pkgutil.iter_modules(bench.__path__) if not m.name.startswith("_")]
    return {name: importlib.import_module(f"samplehd.bench.{name}") for name in sorted(names)}


def _figure_areas() -> list[str]:
    return [name for name, module in _modules().items() if hasattr(module, "run")]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--only", nargs="+", metavar="AREA", help=f"areas to run (default: all of {_figure_areas()})")
    parser.add_argument("--repeats", type=int, default=3, help="repeats per figure (the median is reported)")
    parser.add_argument("--out", type=Path, default=Path("outputs/bench"), help="directory for bench.json")
    parser.add_argument("--report", nargs="?", type=Path, const=Path("docs/PERFORMANCE.md"), metavar="FILE",
                        help="measure the performance table in one run (date, machine, load average, commit; "
                             "wall and per-CPU-second rates; each row's command) and write it between the "
                             "table's markers in FILE (default docs/PERFORMANCE.md), or into a new FILE")
    reports = parser.add_subparsers(dest="area", metavar="AREA", required=False,
                                    help="an area's detailed report (default: the figures table)")
    for name, module in _modules().items():
        if hasattr(module, "add_arguments") and hasattr(module, "report"):
            p = reports.add_parser(name.replace("_", "-"), help=(module.__doc__ or "").splitlines()[0],
                                   description=module.__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
            module.add_arguments(p)
            p.set_defaults(_report=module.report)


def run(args: argparse.Namespace) -> int:
    if getattr(args, "area", None):
        with sigterm_as_interrupt():  # a killed bench stops the processes it times
            return int(args._report(args) or 0)
    if args.repeats < 1:
        raise ConfigError(f"--repeats {args.repeats}: must be an integer ≥ 1")
    if args.report is not None:
        return _report_table(args)
    areas = _figure_areas()
    chosen = args.only or areas
    unknown = [a for a in chosen if a not in areas]
    if unknown:
        raise ConfigError(f"--only: unknown areas {unknown}; valid: {', '.join(areas)}")

    check_out_dir("--out", args.out)
    check_outputs({"--out": args.out})
    console = Console()
    figures = []
    modules = _modules()
    for area in chosen:
        console.print(f"[bold]bench {area}[/bold] ...")
        figures.extend(modules[area].run(repeats=args.repeats))
    table = Table("area", "figure", "median", "unit", "note")
    for f in figures:
        table.add_row(f.area, f.name, f"{f.value:,.3g}" if f.value < 100 else f"{f.value:,.0f}", f.unit, f.note)
    console.print(table)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench.json").write_text(json.dumps([f.to_dict() for f in figures], indent=2))
    console.print(f"wrote {args.out / 'bench.json'}")
    return 0


def _report_table(args: argparse.Namespace) -> int:

    if args.only:
        unknown = [a for a in args.only if a not in _table.AREAS]
        if unknown:
            raise ConfigError(f"--only with --report: unknown areas {unknown}; valid: {', '.join(_table.AREAS)}")
    text = _table.check_target(args.report)  # validate before measuring, write only at the end
    rows, facts = _table.measure(args.repeats, args.only or tuple(_table.AREAS))
    table = _table.table_markdown(rows, facts)
    _table.write_report(args.report, table, text)
    print(table, end="")
    print(f"wrote the table into {args.report}")
    return 0
