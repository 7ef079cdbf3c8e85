"""Task descriptors: the executor's task dict normalised into one typed value per family.

The language executor turns a program into ``{type, objects: [indices], subject}`` where ``subject``
is a table part name, an object index or a list. :func:`parse_task` accepts the forms below and
returns a :class:`Task` that the planner and the success checker share.

=================  ==========================  ===============================================
family             objects                     subject
=================  ==========================  ===============================================
place              moved objects (1 or 2)      destination part ("left"/"right"/"front"/"back")
remove             objects in the cleared part destination part (the executor writes remove as a
                                               place to the opposite part; ``family="remove"``
                                               keeps the name)
stack              [top]                       base object index
put                [object]                    container object index
pick_up            [object]                    None
place_relative     [object]                    reference object index, ``relation`` = direction
stack_three        [middle, top] (move order)  bottom object index (or objects [top, middle,
                                               bottom] with no subject)
=================  ==========================  ===============================================

The type may also carry the parameter in brackets, SAMPLE-HD style: ``place[left]``,
``place_relative[behind]``. Directions are CLEVR's relations left/right/front/behind.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from samplehd.errors import PlanningError
from samplehd.world.layout import OPPOSITE_PART, TABLE_PARTS

__all__ = ["FAMILIES", "RELATION_NAMES", "Task", "parse_task"]

FAMILIES = ("place", "stack", "put", "remove", "pick_up", "place_relative", "stack_three")
RELATION_NAMES = ("left", "right", "front", "behind")
_RELATION_ALIASES = {
    "left": "left", "left_of": "left", "left of": "left", "to the left of": "left",
    "right": "right", "right_of": "right", "right of": "right", "to the right of": "right",
    "front": "front", "in_front_of": "front", "in front of": "front",
    "behind": "behind", "back": "behind", "behind_of": "behind",
}


@dataclass(frozen=True)
class Task:
    """A normalised task.

    Attributes:
        family: one of :data:`FAMILIES`.
        objects: the objects to move, in the order they are moved (stack_three: bottom-up, i.e. the
            middle object first, then the top one).
        part: destination part (place) or cleared part (remove); None otherwise.
        reference: base (stack), container (put), reference (place_relative) or bottom object
            (stack_three); -1 when the family has none.
        direction: relation for place_relative (left/right/front/behind); None otherwise.
    """

    family: str
    objects: tuple[int, ...]
    part: str | None = None
    reference: int = -1
    direction: str | None = None

    @property
    def destination_part(self) -> str | None:
        """The part objects must end in: the part for place, the opposite part for remove."""
        if self.family == "place":
            return self.part
        if self.family == "remove" and self.part:
            return OPPOSITE_PART[self.part]
        return None

    def support_of(self, obj: int) -> int:
        """The object that ``obj`` must end on/in (-1 for the table or the gripper)."""
        if self.family in ("stack", "put"):
            return self.reference
        if self.family == "stack_three":
            # objects = (middle, top); reference = bottom.
            return self.reference if obj == self.objects[0] else self.objects[0]
        return -1

    @property
    def involved(self) -> tuple[int, ...]:
        """Every object the task names (moved objects and the reference)."""
        return self.objects + ((self.reference,) if self.reference >= 0 else ())

    def to_dict(self) -> dict[str, Any]:
        return {
            "family": self.family,
            "objects": list(self.objects),
            "part": self.part,
            "reference": self.reference,
            "direction": self.direction,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Task:
        return cls(
            family=str(d["family"]),
            objects=tuple(int(i) for i in d["objects"]),
            part=d.get("part"),
            reference=int(d.get("reference", -1)),
            direction=d.get("direction"),
        )


def _relation(value: Any) -> str:
    key = str(value).strip().lower()
    if key not in _RELATION_ALIASES:
        raise PlanningError(f"unknown direction {value!r}; valid: {', '.join(RELATION_NAMES)}")
    return _RELATION_ALIASES[key]


def _part(value: Any) -> str:
    if value not in TABLE_PARTS:
        raise PlanningError(f"unknown table part {value!r}; valid: {', '.join(TABLE_PARTS)}")
    return str(value)


def parse_task(task: dict[str, Any] | Task, family: str | None = None) -> Task:
    """Normalise an executor task dict (or a :class:`Task`) into a :class:`Task`.

    Args:
        task: the executor's ``{type, objects, subject, relation}`` (or a :class:`Task`).
        family: the instruction's family when it differs from the task type ("remove" is executed
            as a place to the opposite part).

    Raises:
        PlanningError: unknown family, missing objects or malformed subject; the message says what
            is valid.
    """
    if isinstance(task, Task):
        return task
    if "family" in task and "objects" in task and "type" not in task:
        return Task.from_dict(task)
    raw_type = str(task.get("type", task.get("name", "")))
    m = re.fullmatch(r"([a-z_]+)(?:\[([^\]]+)\])?", raw_type.strip())
    if not m:
        raise PlanningError(f"malformed task type {raw_type!r}; valid families: {', '.join(FAMILIES)}")
    hint = family
    family, param = m.group(1), m.group(2)
    objects = [int(i) for i in task.get("objects", task.get("objectInt", []))]
    subject = task.get("subject")
    if family not in FAMILIES:
        raise PlanningError(f"unknown task family {family!r}; valid: {', '.join(FAMILIES)}")
    if not objects:
        raise PlanningError(f"task {raw_type!r} names no objects")
    if family in ("place", "remove"):
        dest = _part(subject if subject is not None else param)
        if family == "remove" or hint == "remove":
            # The executor's remove is a place to the opposite part; store the cleared part.
            return Task("remove", tuple(objects), part=OPPOSITE_PART[dest])
        return Task(family, tuple(objects), part=dest)
    if family in ("stack", "put"):
        ref = subject if subject is not None else (objects[1] if len(objects) == 2 else None)
        if ref is None or isinstance(ref, list | str):
            raise PlanningError(f"task {family}: subject must be an object index, got {subject!r}")
        moved = objects[:1]
        return Task(family, tuple(moved), reference=int(ref))
    if family == "pick_up":
        return Task(family, (objects[0],))
    if family == "place_relative":
        direction: str | None = _relation(param) if param else None
        if task.get("relation"):
            direction = _relation(task["relation"])
        ref: int | None = None
        if isinstance(subject, dict):
            direction = _relation(subject.get("direction", direction))
            ref = int(subject["reference"])
        elif isinstance(subject, list | tuple):
            for v in subject:
                if isinstance(v, str) and not v.lstrip("-").isdigit():
                    direction = _relation(v)
                else:
                    ref = int(v)
        elif subject is not None:
            ref = int(subject)
        if ref is None and len(objects) == 2:
            ref = objects[1]
        if ref is None or direction is None:
            raise PlanningError(f"task place_relative needs a direction and a reference object, got {task!r}")
        return Task(family, (objects[0],), reference=ref, direction=direction)
    # stack_three: "stack R2 on R3, then R1 on R2" -> move middle then top onto bottom.
    if len(objects) == 3 and subject is None:
        top, middle, bottom = objects
    elif len(objects) == 2 and subject is not None:
        middle, top = objects
        bottom = int(subject)
    else:
        raise PlanningError(f"task stack_three needs three objects (top, middle, bottom), got {task!r}")
    return Task(family, (middle, top), reference=bottom)
