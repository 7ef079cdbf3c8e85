"""File helpers every stage shares: the one JSON reader (one-line errors naming the file and what is
wrong), the one atomic JSON writer and the one file digest."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

from samplehd.errors import DatasetError, SamplehdError

__all__ = ["file_sha256", "read_json", "write_json_atomic"]


def read_json(path: str | Path, error: type[SamplehdError] = DatasetError, label: str | None = None) -> Any:
    """Parse a JSON file (never evaluated: plain data).

    Args:
        path: the file.
        error: the exception class to raise (the caller's area: ConfigError, AssetError, ...).
        label: how to name the file in messages (default: its path), e.g. ``--config run.json``.

    Raises:
        error: ``<label>: cannot read (<reason>)`` or ``<label>: invalid JSON at line L column C: <what>``.
    """
    label = label or str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc).splitlines()[0]
        raise error(f"{label}: cannot read ({reason})") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise error(f"{label}: invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None


def write_json_atomic(path: Path, obj: Any, indent: int | None = None) -> None:
    """Write JSON to a temporary name in the same directory, then rename over ``path``."""
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    tmp.write_text(json.dumps(obj, indent=indent))
    os.replace(tmp, path)


def file_sha256(path: str | Path) -> str:
    """SHA-256 (hex) of a file's bytes, read in 1 MiB blocks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
