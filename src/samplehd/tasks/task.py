"""The one task type: what an instruction asks for, shared by the language executor, the planner, the
success checker and the environment.

A :class:`Task` names its family (:mod:`samplehd.tasks.family`), the objects to move and the family's
parameter (a table part, a reference object, a direction). The language executor builds one from a
program; its executor-dict form ``{type, objects, subject, relation}`` (instruction files) is
:meth:`Task.to_program_dict`, and :func:`parse_task` reads that form (and the forms below) back.

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
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from samplehd.errors import PlanningError
from samplehd.tasks.family import family_names, get_family
from samplehd.world.layout import TABLE_PARTS

__all__ = ["RELATION_NAMES", "Task", "parse_task", "parse_part", "parse_relation"]

RELATION_NAMES = ("left", "right", "front", "behind")
_RELATION_ALIASES = {
    "left": "left", "left_of": "left", "left of": "left", "to the left of": "left",
    "right": "right", "right_of": "right", "right of": "right", "to the right of": "right",
    "front": "front", "in_front_of": "front", "in front of": "front",
    "behind": "behind", "back": "behind", "behind_of": "behind",
}


@dataclass(frozen=True)
class Task:
    """A task.

    Attributes:
        family: a registered family (:func:`samplehd.tasks.family.family_names`).
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
        return get_family(self.family).destination_part(self)

    def support_of(self, obj: int) -> int:
        """The object that ``obj`` must end on/in (-1 for the table or the gripper)."""
        return get_family(self.family).support_of(self, obj)

    @property
    def involved(self) -> tuple[int, ...]:
        """Every object the task names (moved objects, then the reference)."""
        return self.objects + ((self.reference,) if self.reference >= 0 else ())

    @property
    def type(self) -> str:
        """The program action the task is written as (a remove is a place to the opposite part)."""
        return get_family(self.family).program(self)[0]

    @property
    def subject(self) -> str | int | None:
        """The executor's subject: a destination part, the reference object, or None."""
        return get_family(self.family).program(self)[1]

    @property
    def relation(self) -> str | None:
        """The executor's relation (place_relative's direction)."""
        return self.direction

    def to_dict(self) -> dict[str, Any]:
        return {
            "family": self.family,
            "objects": list(self.objects),
            "part": self.part,
            "reference": self.reference,
            "direction": self.direction,
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Task:
        return cls(
            family=str(d["family"]),
            objects=tuple(int(i) for i in d["objects"]),
            part=d.get("part"),
            reference=int(d.get("reference", -1)),
            direction=d.get("direction"),
        )

    def to_program_dict(self) -> dict[str, Any]:
        """The executor's ``{type, objects, subject, relation}`` (the ``task`` of instruction files)."""
        return {"type": self.type, "objects": list(self.objects), "subject": self.subject, "relation": self.relation}

    def to_sample_hd(self) -> dict[str, Any]:
        """SAMPLE-HD's executor output ``{name, objectInt, subjectString, subjectInt}``."""
        subject = self.subject
        return {
            "name": self.type,
            "objectInt": list(self.objects),
            "subjectString": [subject] if isinstance(subject, str) else [],
            "subjectInt": subject if isinstance(subject, int) else -1,
        }


def parse_relation(value: Any) -> str:
    """A direction name (or alias) as one of :data:`RELATION_NAMES`; raises PlanningError."""
    key = str(value).strip().lower()
    if key not in _RELATION_ALIASES:
        raise PlanningError(f"unknown direction {value!r}; valid: {', '.join(RELATION_NAMES)}")
    return _RELATION_ALIASES[key]


def parse_part(value: Any) -> str:
    """A table part name; raises PlanningError naming the valid ones."""
    if value not in TABLE_PARTS:
        raise PlanningError(f"unknown table part {value!r}; valid: {', '.join(TABLE_PARTS)}")
    return str(value)


def parse_task(task: Mapping[str, Any] | Task, family: str | None = None) -> Task:
    """Normalise an executor task dict (or a :class:`Task`) into a :class:`Task`.

    Args:
        task: the executor's ``{type, objects, subject, relation}``, a :meth:`Task.to_dict`, or a
            :class:`Task`.
        family: the instruction's family when it differs from the task type ("remove" is executed
            as a place to the opposite part).

    Raises:
        PlanningError: unknown family, missing objects or malformed subject; the message says what
            is valid.
    """
    if isinstance(task, Task):
        parsed = task
    elif "family" in task and "objects" in task and "type" not in task:
        parsed = Task.from_dict(task)
    else:
        parsed = _parse_program_dict(task)
    if family is not None and family != parsed.family:
        hint = get_family(family)
        if hint.runs_as == parsed.family and hint.adopt is not None:
            return hint.adopt(parsed)
    return parsed


def _parse_program_dict(task: Mapping[str, Any]) -> Task:
    raw_type = str(task.get("type", task.get("name", "")))
    m = re.fullmatch(r"([a-z_]+)(?:\[([^\]]+)\])?", raw_type.strip())
    if not m:
        raise PlanningError(f"malformed task type {raw_type!r}; valid families: {', '.join(family_names())}")
    name, param = m.group(1), m.group(2)
    objects = [int(i) for i in task.get("objects", task.get("objectInt", []))]
    spec = get_family(name)
    if not objects:
        raise PlanningError(f"task {raw_type!r} names no objects")
    return spec.parse(objects, task.get("subject"), param, task)
