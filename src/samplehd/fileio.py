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


def read_json(path: str | Path, error: type[SamplehdError] = DatasetError, label: str | None = None,
              field: str | None = None) -> Any:
    """Parse a JSON file (never evaluated: plain data).

    Args:
        path: the file.
        error: the exception class to raise (the caller's area: ConfigError, AssetError, ...).
        label: how to name the file in messages (default: its path), e.g. ``config=run.json``.
        field: the parameter or config field ``label`` names, when it does (``config``), for the error's ``field``.

    Raises:
        error: ``<label>: cannot read (<reason>)``, ``<label>: invalid JSON at line L column C: <what>``,
            a key given twice in one object, or nesting too deep to parse.
    """
    label = label or str(path)
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
    """SHA-256 (hex) of a file's bytes, read in 1 MiB blocks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
