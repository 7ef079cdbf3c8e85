"""Constraints templates put on their parameters, as a registry of named checks.

A template lists constraints such as ``{"type": "stackable_on", "params": ["R1", "R2"]}``; the
generator evaluates each as soon as all its parameters are drawn and rejects the draw when it
fails, counting the rejection under the constraint's name. Parameter values are an object index
(``object``), a tuple of indices (``object_set``), a table part or a relation name.

Add a constraint with :func:`register_constraint`; its ``param_types`` say what it takes:
``"object"``, ``"objects"`` (an object or an object set), ``"table_part"``, ``"relation"``, and a
trailing ``"*"`` for one or more of that type.

Room at a destination (``room_in_part``, ``room_opposite``, ``free_beside``) is the ground-truth
planner's own free-spot test, run on a grid (:mod:`samplehd.world.free_spot`), so an instruction
is only made when the planner will find where to put its objects.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cache
from typing import Any

from samplehd.language.scene import Scene, SceneObject
from samplehd.world.free_spot import FreeSpots, SpotSearch
from samplehd.world.layout import LAYOUT, OPPOSITE_PART, TableLayout

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
        spot_search: settings of the free-spot test (None: the planner's default margins).
        cache: per-scene memo for expensive checks (filled lazily).
    """

    scene: Scene
    reachable: Reachable = default_reachable
    layout: TableLayout = LAYOUT
    spot_search: SpotSearch | None = None
    cache: dict[Any, Any] = field(default_factory=dict, compare=False)

    def obj(self, index: int) -> SceneObject:
        """Return the scene object with this index."""
        return self.scene.objects[index]

    def reach(self, xyz: Sequence[float]) -> bool:
        """Memoised ``reachable``."""
        if type(xyz) is not tuple:
            return self._reach_rounded(xyz)
        # an object's coordinates, asked again and again: by the exact point first (same point, same rounding)
        exact = ("reach exact", xyz)
        try:
            known = self.cache.get(exact)
        except TypeError:  # unhashable coordinates
            return self._reach_rounded(xyz)
        if known is None:
            known = self.cache[exact] = self._reach_rounded(xyz)
        return known

    def _reach_rounded(self, xyz: Sequence[float]) -> bool:
        """``reachable``, memoised on the point rounded to a micrometre."""
        key = ("reach", *(round(float(v), 6) for v in xyz))
        if key not in self.cache:
            self.cache[key] = bool(self.reachable(xyz))
        return self.cache[key]

    def part_centre(self, part: str) -> tuple[float, float, float]:
        """Centre of a table part on the table top [m] (memoised)."""
        key = ("part centre", part)
        centre = self.cache.get(key)
        if centre is None:
            lo, hi = self.layout.part_bounds(part)
            c = (lo + hi) / 2.0
            centre = self.cache[key] = (float(c[0]), float(c[1]), self.layout.table_height)
        return centre

    def free_spots(self) -> FreeSpots:
        """The planner's free-spot test on this scene (memoised with its candidate spots)."""
        key = ("free_spots",)
        if key not in self.cache:
            search = self.spot_search if self.spot_search is not None else _default_spot_search()
            # the default reach test is the planner's annulus, which every candidate spot passes
            annulus = self.reachable is default_reachable and self.layout == LAYOUT
            self.cache[key] = FreeSpots(self.scene.objects, search, self.layout, self.reach, annulus)
        return self.cache[key]

    def release(self) -> None:
        """Forget what was memoised. The free-spot test's memo refers back to it (its spots' lazy
        computations hold the test, which holds :meth:`reach`), so without this a scene's memo lives on
        until the garbage collector's next full pass."""
        spots = self.cache.get(("free_spots",))
        if spots is not None:
            spots.release()
        self.cache.clear()

    def objects_in(self, part: str) -> tuple[int, ...]:
        """Indices of the objects in a table part."""
        key = ("in", part)
        if key not in self.cache:
            self.cache[key] = tuple(o.index for o in self.scene.objects if part in o.table_part)
        return self.cache[key]


@cache
def _default_spot_search() -> SpotSearch:
    """The planner's default margins (read once: it loads the motion package)."""
    return SpotSearch.from_planner()


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


def _graspable(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    return all(ctx.obj(i).graspable for i in _flatten(params))


def _reachable(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    return all(ctx.reach(ctx.obj(i).coords) for i in _flatten(params))


def _part_reachable(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    return ctx.reach(ctx.part_centre(params[0]))


def _not_in_part(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    part = params[-1]
    return all(part not in ctx.obj(i).table_part for i in _flatten(params[:-1]))


def _room_in_part(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    return ctx.free_spots().room_in_part(_flatten(params[:-1]), params[-1])


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
    return ctx.reach(ctx.part_centre(opposite)) and ctx.free_spots().room_in_part(ctx.objects_in(part), opposite)


def _not_already_related(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    x, y, rel = params
    return x not in ctx.scene.relationships[rel][y]


def _free_beside(ctx: ConstraintContext, params: Sequence[Any]) -> bool:
    x, y, rel = params
    return ctx.free_spots().room_beside(x, y, ctx.scene.directions[rel][:2])


for _name, _check, _types, _doc in (
    ("graspable", _graspable, ("objects*",), "every object can be grasped"),
    ("reachable", _reachable, ("objects*",), "every object is within the arm's reach"),
    ("part_reachable", _part_reachable, ("table_part",), "the table part's centre is reachable"),
    ("not_in_part", _not_in_part, ("objects*", "table_part"), "no object is already in the part"),
    ("room_in_part", _room_in_part, ("objects*", "table_part"), "the planner finds spots for the objects in the part"),
    ("stackable_on", _stackable_on, ("object", "object"), "the base's flat top holds the object"),
    ("fits_in", _fits_in, ("object", "object"), "the object's footprint circle passes the opening"),
    ("part_not_empty", _part_not_empty, ("table_part",), "some object is in the part"),
    ("part_graspable", _part_graspable, ("table_part",), "every object in the part can be moved"),
    ("room_opposite", _room_opposite, ("table_part",), "the planner finds spots for them in the opposite part"),
    ("not_already_related", _not_already_related, ("object", "object", "relation"), "not there yet"),
    ("free_beside", _free_beside, ("object", "object", "relation"), "the planner finds a spot past the reference"),
):
    register_constraint(_name, _check, _types, _doc)
