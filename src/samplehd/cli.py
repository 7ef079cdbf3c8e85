"""The ``samplehd`` command line: a thin layer that parses arguments and calls library code.

Subcommands live in :mod:`samplehd.commands`, one module each, discovered at start-up. A command
module defines ``HELP`` (a one-line string literal), ``add_arguments(parser)`` and ``run(args) -> int``;
the module ``export_mjcf`` becomes the subcommand ``export-mjcf``. Only the module of the command being
run is imported (with the library it needs); the others are listed by their ``HELP``, read from their
source, so ``samplehd --help`` and each command start without loading every stage.
"""

from __future__ import annotations

import argparse
import ast
import importlib
import pkgutil
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import NoReturn

from samplehd import commands
from samplehd.commands._options import DefaultsHelpFormatter, in_flags, option_flags, sigterm_as_interrupt
from samplehd.errors import MissingExtraError, SamplehdError
from samplehd.version import __version__

__all__ = ["build_parser", "main"]


def command_names() -> dict[str, str]:
    """Subcommand name -> module name of every command module (``export-mjcf`` -> ``export_mjcf``)."""
    infos = sorted(pkgutil.iter_modules(commands.__path__), key=lambda i: i.name)
    return {i.name.replace("_", "-"): i.name for i in infos if not i.name.startswith("_")}


def command_help(module_name: str) -> str:
    """The ``HELP`` string literal of a command module, read from its source without importing it."""
    path = Path(commands.__path__[0]) / f"{module_name}.py"
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if (isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "HELP" for t in node.targets)
                and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str)):
            return node.value.value
    raise RuntimeError(f"{path}: a command module needs a one-line HELP string literal")


def _load(module_name: str) -> ModuleType:
    return importlib.import_module(f"{commands.__name__}.{module_name}")


def _chosen(argv: Sequence[str], names: dict[str, str]) -> str | None:
    """The subcommand named on the command line (the first argument that is not an option)."""
    for arg in argv:
        if not arg.startswith("-"):
            return arg if arg in names else None
    return None


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (like every other samplehd error), exit 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser(command: str | None = None, *, full: bool = False) -> argparse.ArgumentParser:
    """Return the top-level parser: ``command``'s subparser complete (every one with ``full``), the
    others with their one-line help."""
    parser = _Parser(
        prog="samplehd",
        description="Simulate a UR5e on a kitchen tabletop and generate language-conditioned "
        "manipulation datasets.",
    )
    parser.add_argument("--version", action="version", version=f"samplehd {__version__}")
    parser.add_argument("--debug", action="store_true", help="show full tracebacks on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module_name in command_names().items():
        if not (full or name == command):
            sub.add_parser(name, help=command_help(module_name))
            continue
        module = _load(module_name)
        p = sub.add_parser(
            name,
            help=module.HELP,
            description=module.__doc__ or module.HELP,
            formatter_class=DefaultsHelpFormatter,
        )
        module.add_arguments(p)
        p.set_defaults(_run=module.run, _parser=p)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the process exit status (0 ok, 1 check failed, 2 bad input)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    chosen = _chosen(argv, command_names())
    try:
        parser = build_parser(chosen)
    except MissingExtraError as exc:  # the command's module needs an extra that is not installed
        print(f"samplehd {chosen}: error: {exc}", file=sys.stderr)
        return 2
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    try:
        # SIGTERM unwinds like Ctrl-C, so every command's worker pools shut down and release their queues.
        with sigterm_as_interrupt():
            return int(args._run(args) or 0)
    except SamplehdError as exc:
        if args.debug:
            traceback.print_exc()
        # The library names its fields; the command line says them as its flags.
        print(f"samplehd {args.command}: error: {in_flags(exc, option_flags(args._parser))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"samplehd {args.command}: interrupted", file=sys.stderr)
        return 130
