"""place: move objects into a table part ("Put the mug on the left side of the table")."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, TypedDict

from samplehd.tasks.checker import Judge
from samplehd.tasks.task import Task, TaskFamily, parse_part, register_family
from samplehd.world.layout import table_parts_of


class PartPlacement(TypedDict):
    """Where a moved object ended (a check's ``details`` entry under the object's index): its position
    in metres, rounded to 0.1 mm, and the table parts it lies in."""

    pos: list[float]
    parts: list[str]


def in_part(j: Judge, t: Task) -> tuple[str, dict[str, PartPlacement]]:
    """place (and remove): every moved object rests on the table inside the destination part (the
    neutral band counts as outside); for remove, none is left in the cleared part."""
    reason = ""
    details: dict[str, PartPlacement] = {}
    dest = t.destination_part
    for i in t.objects:
        parts = table_parts_of(j.pos(i)[:2], j.layout)
        details[str(i)] = {"pos": j.pos(i).round(4).tolist(), "parts": parts}
        if r := j.resting(i):
            reason = r
        elif not j.on_table(i):
            reason = f"object {i} does not rest on the table"
        elif t.family == "remove" and t.part in parts:
            reason = f"object {i} is still in part {t.part}"
        elif dest not in parts:
            reason = f"object {i} is not in part {dest}"
        if reason:
            break
    return reason, details


def _build(objects: Sequence[int], part: Any) -> Task:
    return Task("place", tuple(objects), part=part)


def _parse(objects: list[int], subject: Any, param: str | None, raw: Mapping[str, Any]) -> Task:
    return Task("place", tuple(objects), part=parse_part(subject if subject is not None else param))


FAMILY = register_family(TaskFamily(
    name="place",
    order=0,
    arity=1,
    takes_set=True,
    value="part",
    flat_token="place",
    build=_build,
    parse=_parse,
    program=lambda t: ("place", t.part),
    check=in_part,
    destination="table_part",
    destination_part=lambda t: t.part,
))
