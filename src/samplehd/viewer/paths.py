"""Containment of request paths: every file the viewer reads lies inside one root folder.

A request path is percent-decoded once, split on ``/`` (and ``\\``), and joined under the root;
the result is resolved (symlinks followed) and refused unless it is the root or lies below it.
Encoded traversal (``%2e%2e``), absolute paths, NUL bytes and drive letters are all refused.
"""

from __future__ import annotations

from pathlib import Path, PurePosixPath
from urllib.parse import unquote

from samplehd.errors import DatasetError

__all__ = ["resolve_inside"]


def resolve_inside(root: Path, relative: str) -> Path:
    """The file ``relative`` names under ``root``, resolved; refuses anything outside ``root``.

    Args:
        root: folder every served path must lie in.
        relative: a URL path below ``root`` (may still be percent-encoded).

    Returns:
        The resolved path (it may not exist).

    Raises:
        DatasetError: the path escapes ``root`` (``..``, absolute, symlink out, NUL byte).
    """
    decoded = unquote(relative)
    if "\x00" in decoded:
        raise DatasetError(f"path {relative!r}: contains a NUL byte")
    parts = [p for p in decoded.replace("\\", "/").split("/") if p not in ("", ".")]
    if any(p == ".." or ":" in p for p in parts):
        raise DatasetError(f"path {relative!r}: '..' and drive letters are not allowed")
    base = root.resolve()
    candidate = (base / PurePosixPath(*parts)).resolve() if parts else base
    if candidate != base and not candidate.is_relative_to(base):
        raise DatasetError(f"path {relative!r}: outside the served folder")
    return candidate
