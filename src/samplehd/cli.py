"""The ``samplehd`` command line: a thin layer that parses arguments and calls library code.

Subcommands live in :mod:`samplehd.commands`, one module each, discovered at start-up. A command
module defines ``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int``; the module
``export_mjcf`` becomes the subcommand ``export-mjcf``.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
import traceback
from collections.abc import Sequence
from types import ModuleType

from samplehd import commands
from samplehd.errors import SamplehdError
from samplehd.version import __version__

__all__ = ["build_parser", "main"]


def _command_modules() -> dict[str, ModuleType]:
    found: dict[str, ModuleType] = {}
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        if hasattr(module, "run") and hasattr(module, "add_arguments"):
            found[info.name.replace("_", "-")] = module
    return found


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level parser with one subparser per command module."""
    parser = argparse.ArgumentParser(
        prog="samplehd",
        description="Simulate a UR5e on a kitchen tabletop and generate language-conditioned "
        "manipulation datasets.",
    )
    parser.add_argument("--version", action="version", version=f"samplehd {__version__}")
    parser.add_argument("--debug", action="store_true", help="show full tracebacks on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module in _command_modules().items():
        p = sub.add_parser(
            name,
            help=module.HELP,
            description=module.__doc__ or module.HELP,
            formatter_class=argparse.ArgumentDefaultsHelpFormatter,
        )
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the process exit status (0 ok, 1 check failed, 2 bad input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    try:
        return int(args._run(args) or 0)
    except SamplehdError as exc:
        if args.debug:
            traceback.print_exc()
        print(f"samplehd {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"samplehd {args.command}: interrupted", file=sys.stderr)
        return 130
