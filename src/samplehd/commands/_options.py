"""Helpers shared by the command modules (not a command: the name starts with an underscore)."""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["split_names"]


def split_names(values: str | Sequence[str] | None) -> tuple[str, ...]:
    """Names from repeated and/or comma-separated option values, in order, without repeats."""
    if not values:
        return ()
    items = [values] if isinstance(values, str) else list(values)
    return tuple(dict.fromkeys(n.strip() for item in items for n in item.split(",") if n.strip()))
