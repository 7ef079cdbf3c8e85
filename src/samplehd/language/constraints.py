"""Constraints templates put on their parameters, as a registry of named checks.

A template lists constraints such as ``{"type": "stackable_on", "params": ["R1", "R2"]}``; the
generator evaluates each as soon as all its parameters are drawn and rejects the draw when it
fails, counting the rejection under the constraint's name. Parameter values are an object index
(``object``), a tuple of indices (``object_set``), a table part or a relation name.

Add a constraint with :func:`register_constraint`; its ``param_types`` say what it takes:
``"object"``, ``"objects"`` (an object or an object set), ``"table_part"``, ``"relation"``, and a
trailing ``"*"`` for one or more of that type.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from samplehd.language.scene import Scene, SceneObject
from samplehd.scene.layout import LAYOUT, OPPOSITE_PART, TableLayout

__all__ = [
    "CONSTRAINTS",
    "ConstraintContext",
    "ConstraintSpec",
    "Reachable",
    "default_reachable",
    "register_constraint",
]

Reachable = Callable[[Sequence[float]], bool]


def default_reachable(xyz: Sequence[float]) -> bool:
    """Whether a point is inside the arm's horizontal reach annulus (LAYOUT.in_reach)."""
    return LAYOUT.in_reach((float(xyz[0]), float(xyz[1])))


@dataclass(frozen=True)
class ConstraintContext:
    """What constraint checks may look at.

    Attributes:
        scene: the scene.
        reachable: whether the gripper can pick or place at a point (x, y, z) [m].
        layout: table geometry (table parts, workspace).
        fill_fraction: largest fraction of a table part's area objects may cover after a move.
        relative_gap: gap between an object placed beside another and that object [m].
        cache: per-scene memo for expensive checks (filled lazily).
    """

    scene: Scene
    reachable: Reachable = default_reachable
    layout: TableLayout = LAYOUT
    fill_fraction: float = 0.5
    relative_gap: float = 0.03
    cache: dict[Any, Any] = field(default_factory=dict, compare=False)

    def obj(self, index: int) -> SceneObject:
        """Return the scene object with this index."""
        return self.scene.objects[index]

    def reach(self, xyz: Sequence[float]) -> bool:
        """Memoised ``reachable``."""
        key = ("reach", *(round(float(v), 6) for v in xyz))
        if key not in self.cache:
            self.cache[key] = bool(self.reachable(xyz))
        return self.cache[key]

    def part_centre(self, part: str) -> tuple[float, float, float]:
        """Centre of a table part on the table top [m]."""
        lo, hi = self.layout.part_bounds(part)
        c = (lo + hi) / 2.0
        return (float(c[0]), float(c[1]), self.layout.table_height)

    def part_area(self, part: str) -> float:
        """Area of a table part [m^2]."""
        key = ("area", part)
        if key not in self.cache:
            lo, hi = self.layout.part_bounds(part)
            self.cache[key] = float(np.prod(hi - lo))
        return self.cache[key]

    def occupied_area(self, part: str) -> float:
        """Total footprint area of the objects in a table part [m^2]."""
        key = ("occupied", part)
        if key not in self.cache:
            self.cache[key] = sum(_footprint_area(self.obj(i)) for i in self.objects_in(part))
        return self.cache[key]

    def objects_in(self, part: str) -> tuple[int, ...]:
        """Indices of the objects in a table part."""
        key = ("in", part)
        if key not in self.cache:
            self.cache[key] = tuple(o.index for o in self.scene.objects if part in o.table_part)
        return self.cache[key]


Check = Callable[[ConstraintContext, Sequence[Any]], bool]


@dataclass(frozen=True)
class ConstraintSpec:
    """A named constraint: its check and the parameter types it takes."""

    check: Check
    param_types: tuple[str, ...]
    doc: str = ""

    def accepts(self, types: Sequence[str]) -> bool:
        """Whether parameters of these template types fit ``param_types`` (at most one starred)."""
        pattern = self.param_types
        starred = [i for i, p in enumerate(pattern) if p.endswith("*")]
        if not starred:
            return len(types) == len(pattern) and all(map(_fits, pattern, types))
        s = starred[0]
        before, after = pattern[:s], pattern[s + 1 :]
        if len(types) < len(pattern):
            return False
        middle = types[len(before) : len(types) - len(after)]
        return (
            all(map(_fits, before, types[: len(before)]))
            and all(map(_fits, after, types[len(types) - len(after) :]))
            and all(_fits(pattern[s][:-1], t) for t in middle)
        )


def _fits(want: str, have: str) -> bool:
    return want == have or (want == "objects" and have in ("object", "object_set"))


CONSTRAINTS: dict[str, ConstraintSpec] = {}


def register_constraint(name: str, check: Check, param_types: Sequence[str], doc: str = "") -> None:
    """Add (or replace) a named constraint that templates can use."""
    CONSTRAINTS[name] = ConstraintSpec(check, tuple(param_types), doc)


def _flatten(values: Sequence[Any]) -> list[int]:
    out: list[int] = []
    for v in values:
        if isinstance(v, int):
            out.append(v)
        elif isinstance(v, tuple):
            out.extend(v)
    return out


def _radius(obj: SceneObject) -> float:
    return 0.5 * max(obj.footprint)


def _footprint_area(obj: SceneObject) -> float:
    return obj.footprint[0] * obj.footprint[1]


def _graspable(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    return all(ctx.obj(i).graspable for i in _flatten(params))


def _reachable(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    return all(ctx.reach(ctx.obj(i).coords) for i in _flatten(params))


def _part_reachable(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    return ctx.reach(ctx.part_centre(params[0]))


def _not_in_part(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    part = params[-1]
    return all(part not in ctx.obj(i).table_part for i in _flatten(params[:-1]))


def _room(ctx: ConstraintContext, moved: Sequence[int], part: str) -> bool:
    # objects already in the part stay; moved ones that were elsewhere arrive
    arriving = sum(_footprint_area(ctx.obj(i)) for i in moved if part not in ctx.obj(i).table_part)
    return ctx.occupied_area(part) + arriving <= ctx.fill_fraction * ctx.part_area(part)


def _room_in_part(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    return _room(ctx, _flatten(params[:-1]), params[-1])


def _stackable_on(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    top, base = ctx.obj(params[0]), ctx.obj(params[1])
    if not (top.stackable and base.stackable_on and base.top_extent is not None):
        return False
    # the top's footprint must fit inside the base's flat top (either way round)
    return all(a < b for a, b in zip(sorted(top.footprint), sorted(base.top_extent), strict=True))


def _fits_in(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    obj, container = ctx.obj(params[0]), ctx.obj(params[1])
    if not container.container or container.opening_radius is None:
        return False
    # the footprint's circumscribed circle must pass the opening: it then fits at any yaw
    return 0.5 * math.hypot(*obj.footprint) < container.opening_radius


def _part_not_empty(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    return bool(ctx.objects_in(params[0]))


def _part_graspable(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    inside = ctx.objects_in(params[0])
    return all(ctx.obj(i).graspable and ctx.reach(ctx.obj(i).coords) for i in inside)


def _room_opposite(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    part = params[0]
    opposite = OPPOSITE_PART[part]
    return ctx.reach(ctx.part_centre(opposite)) and _room(ctx, ctx.objects_in(part), opposite)


def _not_already_related(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    x, y, rel = params
    return x not in ctx.scene.relationships[rel][y]


def relative_destination(ctx: ConstraintContext, x: int, y: int, rel: str) -> tuple[float, float, float]:
    """Where object ``x`` goes to be in direction ``rel`` of object ``y`` (x, y, z) [m]."""
    dx, dy = ctx.scene.directions[rel][:2]
    norm = math.hypot(dx, dy) or 1.0
    ox, oy = ctx.obj(x), ctx.obj(y)
    distance = _radius(ox) + _radius(oy) + ctx.relative_gap
    return (oy.coords[0] + dx / norm * distance, oy.coords[1] + dy / norm * distance, ox.coords[2])


def _free_beside(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    x, y, rel = params
    dest = relative_destination(ctx, x, y, rel)
    (x0, y0), (x1, y1) = ctx.layout.workspace_min, ctx.layout.workspace_max
    if not (x0 <= dest[0] <= x1 and y0 <= dest[1] <= y1) or not ctx.reach(dest):
        return False
    rx = _radius(ctx.obj(x))
    for other in ctx.scene.objects:
        if other.index in (x, y):
            continue
        if math.hypot(other.coords[0] - dest[0], other.coords[1] - dest[1]) < rx + _radius(other):
            return False
    return True


for _name, _check, _types, _doc in (
    ("graspable", _graspable, ("objects*",), "every object can be grasped"),
    ("reachable", _reachable, ("objects*",), "every object is within the arm's reach"),
    ("part_reachable", _part_reachable, ("table_part",), "the table part's centre is reachable"),
    ("not_in_part", _not_in_part, ("objects*", "table_part"), "no object is already in the part"),
    ("room_in_part", _room_in_part, ("objects*", "table_part"), "the part has room for the objects"),
    ("stackable_on", _stackable_on, ("object", "object"), "the base's flat top holds the object"),
    ("fits_in", _fits_in, ("object", "object"), "the object's footprint circle passes the opening"),
    ("part_not_empty", _part_not_empty, ("table_part",), "some object is in the part"),
    ("part_graspable", _part_graspable, ("table_part",), "every object in the part can be moved"),
    ("room_opposite", _room_opposite, ("table_part",), "the opposite part has room for them"),
    ("not_already_related", _not_already_related, ("object", "object", "relation"), "not there yet"),
    ("free_beside", _free_beside, ("object", "object", "relation"), "free, reachable spot beside"),
):
    register_constraint(_name, _check, _types, _doc)
