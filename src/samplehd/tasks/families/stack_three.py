"""stack_three: build a stack of three ("Stack the plate on the tray, then the cup on the plate").

``Task.objects`` is (middle, top), the order they are moved; ``reference`` is the bottom object.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from samplehd.errors import PlanningError
from samplehd.tasks.checker import Judge
from samplehd.tasks.task import Task, TaskFamily, register_family


def _check(j: Judge, t: Task) -> tuple[str, dict[str, float]]:
    """Middle on bottom, top on middle (each as for stack)."""
    middle, top = t.objects
    return j.stacked(middle, t.reference) or j.stacked(top, middle), {}


def _build(objects: Sequence[int], value: Any) -> Task:
    top, middle, bottom = objects
    return Task("stack_three", (middle, top), reference=bottom)


def _parse(objects: list[int], subject: Any, param: str | None, raw: Mapping[str, Any]) -> Task:
    # "stack R2 on R3, then R1 on R2" -> move middle then top onto bottom.
    if len(objects) == 3 and subject is None:
        top, middle, bottom = objects
    elif len(objects) == 2 and subject is not None:
        middle, top = objects
        bottom = int(subject)
    else:
        raise PlanningError(f"task stack_three needs three objects (top, middle, bottom), got {dict(raw)!r}")
    return Task("stack_three", (middle, top), reference=bottom)


FAMILY = register_family(TaskFamily(
    name="stack_three",
    order=6,
    arity=3,
    flat_token="stack_three",
    build=_build,
    parse=_parse,
    program=lambda t: ("stack_three", t.reference),
    check=_check,
    destination="top",
    support_of=lambda t, obj: t.reference if obj == t.objects[0] else t.objects[0],
))
