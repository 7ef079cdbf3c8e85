"""Small validators for catalogue data files: every failure is one line naming file, field and fix.

A :class:`Field` wraps a JSON value together with where it came from (``file`` and the dotted
``path`` inside it), so that a validator deep in the tree can still say
``colours.json: colours.red.rgba: expected 4 numbers in [0, 1], got [1, 0]``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from samplehd.errors import AssetError
from samplehd.fileio import read_json as read_json_file

__all__ = ["Field", "is_identifier", "read_json"]


def read_json(path: Path) -> Field:
    """Read a JSON file into a :class:`Field` rooted at the file.

    Args:
        path: file to read.

    Returns:
        The parsed document.

    Raises:
        AssetError: the file is missing or is not valid JSON.
    """
    return Field(read_json_file(path, AssetError), str(path), "")


@dataclass(frozen=True)
class Field:
    """A JSON value and its location, with typed accessors that raise one-line :class:`AssetError`.

    Attributes:
        value: the raw JSON value.
        file: name of the file it came from.
        path: dotted path of the value inside the file ("" for the document root).
    """

    value: Any
    file: str
    path: str

    def fail(self, message: str) -> AssetError:
        """Return an error for this field with ``message`` (say what is valid)."""
        where = self.path or "<root>"
        return AssetError(f"{self.file}: {where}: {message}")

    def child(self, key: str | int, value: Any) -> Field:
        """Return the field for a member ``key`` holding ``value``."""
        sub = f"[{key}]" if isinstance(key, int) else str(key)
        path = f"{self.path}{sub}" if isinstance(key, int) else (f"{self.path}.{sub}" if self.path else sub)
        return Field(value, self.file, path)

    # ----- containers -----
    def mapping(
        self, required: Iterable[str] = (), optional: Iterable[str] = (), *, open_keys: bool = False
    ) -> dict[str, Field]:
        """Check this is an object with exactly the allowed keys; return its members as fields.

        Args:
            required: keys that must be present.
            optional: keys that may be present.
            open_keys: accept any key (for dictionaries keyed by names).
        """
        if not isinstance(self.value, Mapping):
            raise self.fail(f"expected an object, got {_describe(self.value)}")
        required = list(required)
        allowed = set(required) | set(optional)
        if not open_keys:
            unknown = sorted(k for k in self.value if k not in allowed)
            if unknown:
                raise self.child(unknown[0], None).fail(f"unknown key; valid keys are {', '.join(sorted(allowed))}")
        for key in required:
            if key not in self.value:
                raise self.child(key, None).fail("missing required key")
        return {str(k): self.child(str(k), v) for k, v in self.value.items()}

    def items(self) -> Iterator[tuple[str, Field]]:
        """Iterate the members of an object keyed by names (any key allowed)."""
        return iter(self.mapping(open_keys=True).items())

    def sequence(self, min_len: int = 0, max_len: int | None = None) -> list[Field]:
        """Check this is a list with a length in [min_len, max_len]; return its elements."""
        if not isinstance(self.value, list):
            raise self.fail(f"expected a list, got {_describe(self.value)}")
        n = len(self.value)
        if n < min_len or (max_len is not None and n > max_len):
            want = f"{min_len}" if max_len == min_len else f"{min_len}..{max_len if max_len else 'any'}"
            raise self.fail(f"expected a list of {want} elements, got {n}")
        return [self.child(i, v) for i, v in enumerate(self.value)]

    # ----- scalars -----
    def number(self, lo: float | None = None, hi: float | None = None, *, lo_open: bool = False) -> float:
        """Return a finite number inside [lo, hi] (or (lo, hi] with ``lo_open``)."""
        v = self.value
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise self.fail(f"expected a finite number, got {_describe(v)}")
        v = float(v)
        if lo is not None and (v < lo or (lo_open and v == lo)):
            raise self.fail(f"must be {'>' if lo_open else '>='} {lo:g}, got {v:g}")
        if hi is not None and v > hi:
            raise self.fail(f"must be <= {hi:g}, got {v:g}")
        return v

    def positive(self) -> float:
        """Return a number > 0."""
        return self.number(0.0, lo_open=True)

    def numbers(self, n: int, lo: float | None = None, hi: float | None = None) -> tuple[float, ...]:
        """Return exactly ``n`` numbers, each in [lo, hi]."""
        return tuple(f.number(lo, hi) for f in self.sequence(n, n))

    def boolean(self) -> bool:
        """Return a JSON boolean."""
        if not isinstance(self.value, bool):
            raise self.fail(f"expected true or false, got {_describe(self.value)}")
        return self.value

    def string(self) -> str:
        """Return a non-empty string."""
        if not isinstance(self.value, str) or not self.value:
            raise self.fail(f"expected a non-empty string, got {_describe(self.value)}")
        return self.value

    def choice(self, valid: Iterable[str]) -> str:
        """Return a string that is one of ``valid``."""
        valid = list(valid)
        s = self.string()
        if s not in valid:
            raise self.fail(f"unknown value {s!r}; valid values are {', '.join(valid)}")
        return s

    def choices(self, valid: Iterable[str], *, min_len: int = 1) -> tuple[str, ...]:
        """Return a list of distinct strings from ``valid`` (at least ``min_len``)."""
        valid = list(valid)
        out = tuple(f.choice(valid) for f in self.sequence(min_len))
        if len(set(out)) != len(out):
            raise self.fail(f"values must be distinct, got {list(out)}")
        return out

    def name(self) -> str:
        """Return an identifier: lower-case letters, digits and underscores, starting with a letter."""
        s = self.string()
        if not is_identifier(s):
            raise self.fail(f"invalid name {s!r}; use lower-case letters, digits and '_', starting with a letter")
        return s


_NAME_CHARS = frozenset("abcdefghijklmnopqrstuvwxyz0123456789_")


def is_identifier(s: str) -> bool:
    """Whether ``s`` is a valid catalogue name (lower-case snake case, starting with a letter)."""
    return bool(s) and s[0].isalpha() and all(c in _NAME_CHARS for c in s)


def _describe(v: Any) -> str:
    text = json.dumps(v) if not isinstance(v, float) or math.isfinite(v) else str(v)
    if len(text) > 40:
        text = text[:37] + "..."
    return f"{type(v).__name__} {text}" if not isinstance(v, dict | list) else text
