"""remove: clear a table part, moving its objects to the opposite part ("Clear the right side").

Its program is a place to the opposite part (SAMPLE-HD writes it so); ``Task.part`` is the cleared part.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from samplehd.tasks.families.place import in_part
from samplehd.tasks.task import Task, TaskFamily, parse_part, register_family
from samplehd.world.layout import OPPOSITE_PART


def _build(objects: Sequence[int], part: Any) -> Task:
    # The executor runs remove as the place it is written as.
    return Task("place", tuple(objects), part=OPPOSITE_PART[part])


def _parse(objects: list[int], subject: Any, param: str | None, raw: Mapping[str, Any]) -> Task:
    dest = parse_part(subject if subject is not None else param)
    return Task("remove", tuple(objects), part=OPPOSITE_PART[dest])


def _adopt(task: Task) -> Task:
    """The remove a place task was written for: the cleared part is opposite the destination."""
    return Task("remove", task.objects, part=OPPOSITE_PART[task.part])


FAMILY = register_family(TaskFamily(
    name="remove",
    order=1,
    arity=1,
    takes_set=True,
    value="part",
    build=_build,
    parse=_parse,
    program=lambda t: ("place", OPPOSITE_PART[t.part] if t.part else None),
    check=in_part,
    destination="table_part",
    destination_part=lambda t: OPPOSITE_PART[t.part] if t.part else None,
    runs_as="place",
    adopt=_adopt,
    # "place[back] scene filter_table[front]": everything on one part goes to the other one
    written_as=lambda program: len(program) == 3 and program[2].startswith("filter_table["),
))
