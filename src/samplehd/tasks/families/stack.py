"""stack: put an object on top of another ("Stack the cup on the plate")."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from samplehd.errors import PlanningError
from samplehd.tasks.checker import Judge
from samplehd.tasks.task import Task, TaskFamily, register_family


def build_on(name: str) -> Callable[[Sequence[int], Any], Task]:
    """The action builder of a family that moves one object onto or into a reference object."""

    def build(objects: Sequence[int], value: Any) -> Task:
        return Task(name, (objects[0],), reference=objects[1])

    return build


def parse_on(name: str) -> Callable[[list[int], Any, str | None, Mapping[str, Any]], Task]:
    """The executor-dict parser of a family that moves one object onto or into a reference object."""

    def parse(objects: list[int], subject: Any, param: str | None, raw: Mapping[str, Any]) -> Task:
        ref = subject if subject is not None else (objects[1] if len(objects) == 2 else None)
        if ref is None or isinstance(ref, list | str):
            raise PlanningError(f"task {name}: subject must be an object index, got {subject!r}")
        return Task(name, tuple(objects[:1]), reference=int(ref))

    return parse


def _check(j: Judge, t: Task) -> tuple[str, dict[str, float]]:
    """The object rests on the base (touching it, above its bottom, over its footprint)."""
    return j.stacked(t.objects[0], t.reference), {}


FAMILY = register_family(TaskFamily(
    name="stack",
    order=2,
    arity=2,
    flat_token="stack",
    build=build_on("stack"),
    parse=parse_on("stack"),
    program=lambda t: ("stack", t.reference),
    check=_check,
    destination="top",
    support_of=lambda t, obj: t.reference,
))
