"""Where user data lives: the registry of imported classes and the cache of decompositions.

Both directories can be moved with environment variables (useful for tests and clusters):
``SAMPLEHD_REGISTRY_DIR`` (default ``$XDG_DATA_HOME/samplehd/assets``, i.e.
``~/.local/share/samplehd/assets``) and ``SAMPLEHD_CACHE_DIR`` (default ``$XDG_CACHE_HOME/samplehd``,
i.e. ``~/.cache/samplehd``).
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["cache_dir", "refresh", "registry_dir"]


def registry_dir() -> Path:
    """Directory of imported classes, one sub-directory per class (may not exist yet)."""
    env = os.environ.get("SAMPLEHD_REGISTRY_DIR")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "samplehd" / "assets"


def cache_dir() -> Path:
    """Directory of cached convex decompositions (may not exist yet)."""
    env = os.environ.get("SAMPLEHD_CACHE_DIR")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "samplehd"


def refresh() -> None:
    """Forget the cached catalogue so that the next load sees registry changes."""
    from samplehd.catalogue import loader

    loader._load_cached.cache_clear()
