"""Helpers shared by the command modules (not a command: the name starts with an underscore): names
from option values, and checks of options that raise a one-line ConfigError naming the flag, the
value and what is valid, before the command writes anything."""

from __future__ import annotations

import argparse
import math
import re
import signal
import threading
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

from samplehd.errors import ConfigError, SamplehdError

C = TypeVar("C")

__all__ = ["DefaultsHelpFormatter", "add_render_preset", "check_int", "check_names", "check_number", "check_out_dir",
           "check_out_file", "config_from_options", "in_flags", "option_flags", "sigterm_as_interrupt", "split_names"]


_STATES_DEFAULT = re.compile(r"\bdefault[: ]", re.IGNORECASE)  # "(default 10)", "default: all", not "by default)"


class DefaultsHelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Help that appends an option's default once: not where the help text already speaks of its default,
    not for an unset (None) or off (False) default, and a list default as its words ("rgb depth")."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if _STATES_DEFAULT.search(text) or default is None or default is False or default == argparse.SUPPRESS:
            return action.help
        if not (action.option_strings or action.nargs in (argparse.OPTIONAL, argparse.ZERO_OR_MORE)):
            return action.help
        if isinstance(default, (list, tuple)):
            words = " ".join(str(v) for v in default) or "none"
            return f"{text} (default: {words.replace('%', '%%')})"
        return f"{text} (default: %(default)s)"


_FIELD_REFERENCE = re.compile(r"`([a-z][a-z0-9_]*)`")


def option_flags(parser: argparse.ArgumentParser) -> dict[str, str]:
    """Each option's destination -> its first flag (``render_preset`` -> ``--render-preset``), sub-commands'
    options included."""
    flags: dict[str, str] = {}
    for action in parser._actions:
        if action.option_strings:
            flags.setdefault(action.dest, action.option_strings[0])
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                for dest, flag in option_flags(sub).items():
                    flags.setdefault(dest, flag)
    return flags


def in_flags(exc: SamplehdError, flags: Mapping[str, str]) -> str:
    """The message of a library error in the command line's words. The library names its parameters and
    config fields: the subject of a message about one (``ray_address='x': ...``, ``resume: ...``, with
    ``exc.field`` set) and, in backticks, the ones its advice mentions (``pass `resume` to continue it``).
    Here each becomes its flag from ``flags`` (:func:`option_flags`): ``--ray-address 'x': ...``,
    ``--resume: ...``, ``pass --resume to continue it``. A subject with no flag of its own is said as
    ``--`` and the field with ``-`` for ``_``; a backticked name that is no option stays as it is.
    """
    text, field = str(exc), exc.field
    if field:
        flag = flags.get(field) or "--" + field.replace("_", "-")
        if text.startswith(f"{field}="):
            text = f"{flag} {text[len(field) + 1:]}"
        elif text.startswith(f"{field}:"):
            text = flag + text[len(field):]
    return _FIELD_REFERENCE.sub(lambda m: flags.get(m.group(1), m.group(0)), text)


def config_from_options(cls: type[C], **values: Any) -> C:
    """``cls(**values)``, a :class:`samplehd.schema.Config` whose fields the command's options fill one by
    one (each field named as its option's destination). A refused value's message loses the config's
    section and carries the field (``EvalConfig.episodes=0: ...`` -> ``episodes=0: ...``), which
    :func:`in_flags` says as the flag: ``--episodes 0: ...``."""
    try:
        return cls(**values)
    except ConfigError as exc:
        text, prefix = str(exc), f"{cls._section}."  # type: ignore[attr-defined]
        name = text[len(prefix):].split("=", 1)[0].split(":", 1)[0] if text.startswith(prefix) else ""
        if name in values:
            raise ConfigError(text[len(prefix):], field=name) from None
        raise


def add_render_preset(parser: argparse.ArgumentParser, presets: Sequence[str], default: str,
                      help: str = "render quality preset") -> None:
    """``--render-preset NAME`` (dest ``render_preset``), one of ``presets`` (the render floor's list,
    ``samplehd.render.image_spec.PRESET_NAMES``, passed in so that this module loads no renderer).
    ``--preset`` stays an alias: it was the flag's name before ``generate --preset`` (a dataset preset) made
    the word ambiguous, and scripts may use it."""
    parser.add_argument("--render-preset", "--preset", dest="render_preset", choices=list(presets), default=default,
                        help=f"{help} (--preset: the same, its former name)")


def check_int(flag: str, value: int | None, lo: int | None = None, hi: int | None = None) -> None:
    """``value`` (None: not given) is an integer in ``lo..hi``."""
    if value is None:
        return
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        if lo is not None and hi is not None:
            want = f"in {lo}..{hi}"
        else:
            want = f"≥ {lo}" if lo is not None else f"≤ {hi}"
        raise ConfigError(f"{flag} {value}: must be an integer {want}")


def check_number(flag: str, value: float | None, lo: float = 0.0, lo_open: bool = True) -> None:
    """``value`` (None: not given) is finite and above ``lo`` (or at least ``lo``)."""
    if value is None:
        return
    if not math.isfinite(value) or value < lo or (lo_open and value == lo):
        raise ConfigError(f"{flag} {value}: must be a finite number {'>' if lo_open else '≥'} {lo:g}")


def split_names(values: str | Sequence[str] | None, flag: str) -> tuple[str, ...]:
    """Names from repeated and/or comma-separated option values, in order; a name given twice is an
    error (as it is in config files), never silently dropped."""
    if not values:
        return ()
    items = [values] if isinstance(values, str) else list(values)
    names = tuple(n.strip() for item in items for n in item.split(",") if n.strip())
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ConfigError(f"{flag} {' '.join(names)}: names {', '.join(twice)} twice; give each once")
    return names


def check_names(flag: str, names: Iterable[str] | None, valid: Sequence[str], allow_empty: bool = False) -> None:
    """Every name is one of ``valid``, none twice, and (unless ``allow_empty``) at least one."""
    if names is None:
        return
    names = list(names)
    bad = [n for n in names if n not in valid]
    if bad:
        raise ConfigError(f"{flag}: unknown {', '.join(map(repr, bad))}; valid: {', '.join(valid)}")
    if not names and not allow_empty:
        raise ConfigError(f"{flag}: give at least one of {', '.join(valid)}")
    if len(set(names)) != len(names):
        raise ConfigError(f"{flag} {' '.join(names)}: names an item twice")


def check_out_file(flag: str, path: Path | None, suffixes: Sequence[str]) -> None:
    """``path`` (None: not given) can become a file: the right suffix, not a folder, its parent not a file."""
    if path is None:
        return
    if suffixes and path.suffix.lower() not in suffixes:
        raise ConfigError(f"{flag} {path}: must end in {' or '.join(suffixes)}")
    if path.is_dir():
        raise ConfigError(f"{flag} {path}: is a folder; give a file name ending in {' or '.join(suffixes)}")
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise ConfigError(f"{flag} {path}: {parent} is a file, not a folder")
            break


def check_out_dir(flag: str, path: Path | None, empty: bool = False) -> None:
    """``path`` (None: not given) can become a folder: not a file, no file among its parents, and
    (with ``empty``) new or empty."""
    if path is None:
        return
    if path.exists() and not path.is_dir():
        raise ConfigError(f"{flag} {path}: is a file; give a folder")
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise ConfigError(f"{flag} {path}: {parent} is a file, not a folder")
            break
    if empty and path.is_dir() and any(path.iterdir()):
        raise ConfigError(f"{flag} {path}: exists and is not empty; choose a new or empty folder")


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


@contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM stops the command as Ctrl-C does: the interrupt unwinds through the
    command's cleanup (worker pools shut down, their queues' semaphores released) instead of the default
    action ending the process on the spot, which leaves those semaphores to Python's resource tracker
    and its "leaked semaphore" warning. The previous handler is restored after the block; off the main
    thread (where no handler can be set) the block runs unchanged."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
