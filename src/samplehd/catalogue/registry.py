"""Where user data lives: the registry of imported classes and the cache of decompositions.

Imported classes are user data: a catalogue contains them only when a config or a flag names them
(see :func:`samplehd.catalogue.loader.load_catalogue`), so importing a mesh never changes what a
seeded run without that name produces.

Both directories can be moved with environment variables (useful for tests and clusters):
``SAMPLEHD_REGISTRY_DIR`` (default ``$XDG_DATA_HOME/samplehd/assets``, i.e.
``~/.local/share/samplehd/assets``) and ``SAMPLEHD_CACHE_DIR`` (default ``$XDG_CACHE_HOME/samplehd``,
i.e. ``~/.cache/samplehd``).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from samplehd.catalogue.schema import is_identifier
from samplehd.errors import AssetError

__all__ = ["cache_dir", "generation", "refresh", "registered_classes", "registry_dir", "remove_imported"]

_generation = 0  # bumped on every registry change this process makes; part of the catalogue cache key


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
    """Say that the registry changed, so that the next catalogue load reads it again."""
    global _generation
    _generation += 1


def generation() -> int:
    """How many registry changes this process has made (see :func:`refresh`)."""
    return _generation


def remove_imported(name: str) -> None:
    """Delete an imported class from the registry.

    Raises:
        AssetError: no imported class of that name.
    """
    target = registry_dir() / name
    if not is_identifier(name) or not (target / "class.json").is_file():
        raise AssetError(f"no imported class named {name!r} in {registry_dir()}")
    shutil.rmtree(target)
    refresh()


def registered_classes(registry: Path | None = None) -> tuple[str, ...]:
    """Names of the classes imported into ``registry`` (default :func:`registry_dir`), sorted."""
    base = registry_dir() if registry is None else Path(registry)
    if not base.is_dir():
        return ()
    return tuple(sorted(p.parent.name for p in base.glob("*/class.json")))
