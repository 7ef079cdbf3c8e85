"""File helpers every stage shares: the one JSON reader (one-line errors naming the file and what is
wrong), the one atomic JSON writer and the one file digest.

A ``to_dict`` method annotated ``-> dict[str, object]`` gives a record's JSON form, which goes to
``json.dumps`` (or :func:`write_json_atomic`) as is: that is the JSON boundary, and its keys are
documented where the record's format is."""

from __future__ import annotations

import errno
import hashlib
import json
import os
import stat
from pathlib import Path
from typing import Any

from samplehd.errors import DatasetError, SamplehdError

__all__ = ["check_regular_file", "file_sha256", "not_a_regular_file", "read_json", "resolve_path",
           "write_json_atomic"]


def not_a_regular_file(path: str | Path) -> str | None:
    """Why ``path`` cannot be read as a file without the risk of waiting forever, or None when it is a
    regular file (or does not exist: the caller's own read says so). A FIFO, socket or device blocks
    or streams on ``open``; a loop of symbolic links never resolves.

    Returns:
        ``"a named pipe (FIFO)"``, ``"a socket"``, ``"a device"``, ``"a folder"``, ``"a loop of
        symbolic links"`` or None.
    """
    try:
        mode = os.stat(path).st_mode
    except OSError as exc:
        return "a loop of symbolic links" if exc.errno == errno.ELOOP else None
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a named pipe (FIFO)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "a device"


def check_regular_file(path: str | Path, error: type[SamplehdError] = DatasetError, label: str | None = None,
                       field: str | None = None) -> None:
    """Refuse, before anything opens it, a ``path`` that is no regular file (:func:`not_a_regular_file`).

    Raises:
        error: ``<label>: is a named pipe (FIFO), not a file; give a regular file``.
    """
    why = not_a_regular_file(path)
    if why is not None:
        raise error(f"{label or path}: is {why}, not a file; give a regular file", field=field)


def resolve_path(path: Path, error: type[SamplehdError] = DatasetError, label: str | None = None,
                 field: str | None = None) -> Path:
    """``path.resolve()``; a loop of symbolic links (which Python reports as a RuntimeError or an
    ``ELOOP`` OSError) is one line naming the path.

    Raises:
        error: ``<label>: is a loop of symbolic links; give a real file or folder``.
    """
    try:
        return path.resolve()
    except (RuntimeError, OSError):
        raise error(f"{label or path}: is a loop of symbolic links (or lies inside one); give a real file or "
                    f"folder", field=field) from None


def read_json(path: str | Path, error: type[SamplehdError] = DatasetError, label: str | None = None,
              field: str | None = None) -> Any:
    """Parse a JSON file (never evaluated: plain data).

    Args:
        path: the file.
        error: the exception class to raise (the caller's area: ConfigError, AssetError, ...).
        label: how to name the file in messages (default: its path), e.g. ``config=run.json``.
        field: the parameter or config field ``label`` names, when it does (``config``), for the error's ``field``.

    Raises:
        error: ``<label>: cannot read (<reason>)``, no regular file (a FIFO would block the read),
            ``<label>: invalid JSON at line L column C: <what>``,
            a key given twice in one object, or nesting too deep to parse.
    """
    label = label or str(path)
    check_regular_file(path, error, label, field)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc).splitlines()[0]
        raise error(f"{label}: cannot read ({reason})", field=field) from None
    try:
        return json.loads(text, object_pairs_hook=_unique_keys)
    except json.JSONDecodeError as exc:
        raise error(f"{label}: invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}", field=field) from None
    except _DuplicateKey as exc:
        raise error(f"{label}: key {exc.args[0]!r} appears twice in one object (which one counts is not "
                    f"clear); keep one", field=field) from None
    except RecursionError:
        raise error(f"{label}: JSON nested too deeply to read (arrays or objects inside each other "
                    f"thousands of times); not a samplehd file", field=field) from None


class _DuplicateKey(ValueError):
    """A JSON object holds one key twice (raised inside the parser, turned into the caller's error)."""


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise _DuplicateKey(key)
        out[key] = value
    return out


def write_json_atomic(path: Path, obj: Any, indent: int | None = None) -> None:
    """Write JSON to a temporary name in the same directory, then rename over ``path``."""
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    tmp.write_text(json.dumps(obj, indent=indent))
    os.replace(tmp, path)


def file_sha256(path: str | Path) -> str:
    """SHA-256 (hex) of a file's bytes, read in 1 MiB blocks.

    Raises:
        DatasetError: ``path`` is no regular file (a FIFO would block the read forever).
    """
    check_regular_file(path)
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
