"""Episodes as the viewer sees them (placeholder until the dataset reader lands)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["open_episode_store"]


def open_episode_store(root: Path) -> Any | None:
    """The episode store of a dataset folder, or None when it holds no episodes."""
    return None
