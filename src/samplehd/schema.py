"""Config schemas declared once: dataclass fields carry their type hint and bounds; one checker validates.

A config is a frozen dataclass that derives from :class:`Config` (``class PathConfig(Config, section="paths")``)
and declares each field with its type and, where a range or a set of names applies, :func:`bounded` metadata.
:class:`Config` gives it, once for all configs, a ``__post_init__`` that calls :func:`check_fields` (a config
with a rule across fields extends it and calls ``super().__post_init__()`` first), ``to_dict``
(:func:`to_mapping`) and ``from_dict`` (:func:`from_mapping`). :func:`check_fields`

- checks every field against its type hint: ``int`` (not bool), ``float`` (finite; ints become floats),
  ``bool``, ``str``, ``X | None``, ``tuple[str, ...]`` (a list or tuple, never a string),
  ``tuple[int, int]``, a mapping, or a nested config dataclass, alone or as the items of a
  ``tuple[X, ...]`` (a mapping is built with :func:`from_mapping`);
- checks the declared bounds (``lo``/``hi``, open or closed), names (``choices``), non-empty and
  distinct lists, and a list's length;
- normalises lists to tuples so frozen configs stay hashable and compare equal to their JSON round trip.

:func:`from_mapping` builds a config from a JSON object: anything but an object, and any unknown key,
is an error naming the valid keys. Every message is one line: ``section.field=value: what is valid``.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import types
import typing
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Self, TypeVar

from samplehd.errors import ConfigError

__all__ = ["Bounds", "Config", "bounded", "check_fields", "from_mapping", "json_type_name", "to_mapping"]

T = TypeVar("T")


@dataclass(frozen=True)
class Bounds:
    """What a field's value may be, beyond its type.

    Attributes:
        lo: smallest value (numbers) or None.
        hi: largest value (numbers) or None.
        lo_open: ``lo`` itself is not allowed.
        hi_open: ``hi`` itself is not allowed.
        unit: unit shown in messages (e.g. ``m``, ``s``, ``px``).
        choices: valid names (a string, or every item of a list of strings), or a function returning
            them (a registry that grows as modules register into it).
        nonempty: a list must have at least one item.
        unique: a list's items must be distinct.
    """

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    unit: str = ""
    choices: tuple[str, ...] | Callable[[], Sequence[str]] | None = None
    nonempty: bool = False
    unique: bool = False

    def describe(self) -> str:
        """The valid range in words, e.g. ``in (0, 10] s`` or ``≥ 1``."""
        unit = f" {self.unit}" if self.unit else ""
        if self.lo is not None and self.hi is not None:
            return (f"in {'(' if self.lo_open else '['}{_num(self.lo)}, {_num(self.hi)}"
                    f"{')' if self.hi_open else ']'}{unit}")
        if self.lo is not None:
            return f"{'>' if self.lo_open else '≥'} {_num(self.lo)}{unit}"
        if self.hi is not None:
            return f"{'<' if self.hi_open else '≤'} {_num(self.hi)}{unit}"
        return ""

    def names(self) -> tuple[str, ...] | None:
        """The valid names now (None: any)."""
        if self.choices is None:
            return None
        return tuple(self.choices() if callable(self.choices) else self.choices)

    def admits(self, v: float) -> bool:
        if self.lo is not None and (v < self.lo or (self.lo_open and v == self.lo)):
            return False
        return not (self.hi is not None and (v > self.hi or (self.hi_open and v == self.hi)))


def _num(v: float) -> str:
    return str(int(v)) if float(v).is_integer() and abs(v) < 1e15 else repr(v)


def bounded(default: Any = dataclasses.MISSING, *, default_factory: Any = dataclasses.MISSING,
            **bounds: Any) -> Any:
    """A dataclass field with :class:`Bounds` (keyword arguments) in its metadata."""
    if bounds.get("choices") is not None and not callable(bounds["choices"]):
        bounds["choices"] = tuple(bounds["choices"])
    meta = {"bounds": Bounds(**bounds)}
    if default_factory is not dataclasses.MISSING:
        return dataclasses.field(default_factory=default_factory, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def json_type_name(value: Any) -> str:
    """The JSON name of a value's type (for messages)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int | float):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, Mapping):
        return "an object"
    if isinstance(value, list | tuple):
        return "a list"
    return type(value).__name__


_HINTS: dict[type, dict[str, Any]] = {}


def _hints(cls: type) -> dict[str, Any]:
    if cls not in _HINTS:
        _HINTS[cls] = typing.get_type_hints(cls)
    return _HINTS[cls]


def _fail(where: str, name: str, value: Any, what: str) -> typing.NoReturn:
    raise ConfigError(f"{where}.{name}={_show(value)}: {what}")


def _show(value: Any) -> str:
    if isinstance(value, tuple):
        value = list(value)
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _is_int(v: Any) -> bool:
    """An integer, NumPy's included (``np.int64(64)``: what array arithmetic hands a caller); not a bool."""
    return isinstance(v, numbers.Integral) and not isinstance(v, bool)


def _is_number(v: Any) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def _split_optional(hint: Any) -> tuple[Any, bool]:
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        if len(args) == 1 and len(typing.get_args(hint)) == 2:
            return args[0], True
    return hint, False


def _check(where: str, name: str, value: Any, hint: Any, b: Bounds) -> Any:
    """Check one value against its hint and bounds; returns the normalised value."""
    hint, optional = _split_optional(hint)
    if value is None:
        if optional:
            return None
        _fail(where, name, value, f"must not be null; {_want(hint, b)}")
    if hint is Any:
        return value
    origin = typing.get_origin(hint)
    if hint is bool:
        if not isinstance(value, bool):
            _fail(where, name, value, "must be true or false")
        return value
    if hint is int:
        if not _is_int(value) or not b.admits(value):
            _fail(where, name, value, _want(hint, b))
        return value if type(value) is int else int(value)
    if hint is float:
        if not _is_number(value) or not math.isfinite(value) or not b.admits(value):
            _fail(where, name, value, _want(hint, b))
        return float(value)
    if hint is str:
        if not isinstance(value, str) or (b.choices is not None and value not in b.names()):
            _fail(where, name, value, _want(hint, b))
        return value
    if origin is tuple:
        args = typing.get_args(hint)
        if not isinstance(value, list | tuple):
            _fail(where, name, value, _want(hint, b))
        items = tuple(value)
        if len(args) == 2 and args[1] is Ellipsis:
            item_hint = args[0]
            if isinstance(item_hint, type) and dataclasses.is_dataclass(item_hint):
                items = tuple(_check(where, f"{name}[{i}]", item, item_hint, Bounds()) for i, item in enumerate(items))
            for i, item in enumerate(items):
                if item_hint is str and not isinstance(item, str):
                    _fail(where, name, value, f"item {i} is {json_type_name(item)}; {_want(hint, b)}")
                if item_hint is str and b.choices is not None and item not in b.names():
                    _fail(where, name, value, f"unknown {item!r}; valid: {', '.join(b.names())}")
                if item_hint in (int, float):
                    _check(where, f"{name}[{i}]", item, item_hint, b)
            if b.nonempty and not items:
                _fail(where, name, value, f"must not be empty; {_want(hint, b)}")
            if b.unique and len(set(items)) != len(items):
                _fail(where, name, value, "must not name an item twice")
            return tuple(float(x) if item_hint is float else int(x) if item_hint is int else x for x in items)
        if len(items) != len(args):
            _fail(where, name, value, _want(hint, b))
        return tuple(_check(where, f"{name}[{i}]", x, a, b) for i, (x, a) in enumerate(zip(items, args, strict=True)))
    if origin in (dict, Mapping) or hint is dict:
        if not isinstance(value, Mapping):
            _fail(where, name, value, "must be a JSON object")
        return value
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        if isinstance(value, hint):
            return value
        if isinstance(value, Mapping):
            return from_mapping(hint, value, f"{where}.{name}")
        _fail(where, name, value, f"must be a JSON object of {name} options")
    return value


def _want(hint: Any, b: Bounds) -> str:
    rng = b.describe()
    if hint is int:
        return f"must be an integer{' ' + rng if rng else ''}"
    if hint is float:
        return f"must be a finite number{' ' + rng if rng else ''}"
    names = b.names()
    if hint is str:
        return f"valid: {', '.join(names)}" if names is not None else "must be a string"
    if typing.get_origin(hint) is tuple:
        args = typing.get_args(hint)
        if len(args) == 2 and args[1] is Ellipsis:
            kind = {str: "names", int: "integers", float: "numbers"}.get(args[0], "values")
            if names:
                return f"must be a list of {kind} from {', '.join(names)}, e.g. [\"{names[0]}\"]"
            return f"must be a list of {kind}{' ' + rng if rng else ''}"
        return f"must be a list of {len(args)} values{' ' + rng if rng else ''}"
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return "must be a JSON object"
    return "has the wrong type"


def check_fields(obj: Any, where: str, skip: Iterable[str] = ()) -> None:
    """Validate (and normalise in place) every field of the dataclass ``obj`` from its declaration.

    Args:
        obj: a dataclass instance (frozen ones too).
        where: the section name messages start with (e.g. ``scene``, ``paths.planner``).
        skip: fields the caller checks itself.

    Raises:
        ConfigError: one line naming ``where.field``, the bad value and what is valid.
    """
    hints = _hints(type(obj))
    skipped = set(skip)
    for f in dataclasses.fields(obj):
        if f.name in skipped:
            continue
        value = getattr(obj, f.name)
        b = f.metadata.get("bounds", Bounds())
        new = _check(where, f.name, value, hints[f.name], b)
        if new is not value:
            object.__setattr__(obj, f.name, new)


def from_mapping(cls: type[T], d: Any, where: str) -> T:
    """Build the config dataclass ``cls`` from a JSON object; unknown keys are errors.

    Raises:
        ConfigError: ``d`` is not an object, has a key ``cls`` does not know, lacks one without a default,
            or has a bad value.
    """
    if not isinstance(d, Mapping):
        raise ConfigError(f"{where}: must be a JSON object of options, got {json_type_name(d)}")
    valid = [f.name for f in dataclasses.fields(cls) if f.init]
    unknown = sorted(str(k) for k in d if k not in valid)
    if unknown:
        raise ConfigError(f"{where}: unknown option(s) {unknown}; valid: {', '.join(valid)}")
    missing = [f.name for f in dataclasses.fields(cls) if f.init and f.name not in d
               and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
    if missing:
        raise ConfigError(f"{where}: missing option(s) {missing}")
    return cls(**d)


def to_mapping(obj: Any) -> dict[str, Any]:
    """The JSON object of a config dataclass: every field in declaration order, lists and tuples as lists,
    nested configs by their own ``to_dict``."""
    return {f.name: _json_value(getattr(obj, f.name)) for f in dataclasses.fields(obj)}


def _json_value(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type) and hasattr(value, "to_dict"):
        return value.to_dict()
    if isinstance(value, list | tuple):
        return [_json_value(v) for v in value]
    if isinstance(value, Mapping):
        return {k: _json_value(v) for k, v in value.items()}
    return value


class Config:
    """Base of every config dataclass: validation from the declaration, ``to_dict`` and ``from_dict``.

    A subclass names the section its messages start with: ``class SafetyConfig(Config, section="SafetyConfig")``.
    """

    _section: ClassVar[str] = "config"

    def __init_subclass__(cls, section: str | None = None, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if section is not None:
            cls._section = section

    def __post_init__(self) -> None:
        check_fields(self, self._section)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready options (:func:`to_mapping`)."""
        return to_mapping(self)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str | None = None) -> Self:
        """Build from a JSON object; unknown keys are errors (:func:`from_mapping`). ``where``: the section
        messages start with (default: the class's own)."""
        return from_mapping(cls, d, cls._section if where is None else where)
