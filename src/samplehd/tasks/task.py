"""The one task type: what an instruction asks for, shared by the language executor, the planner, the
success checker and the environment.

A :class:`Task` names its family (:mod:`samplehd.tasks.task`), the objects to move and the family's
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

The registry of task families lives here too: each family is declared once, in its own module of
:mod:`samplehd.tasks.families`, as a :class:`TaskFamily`:

- **language**: how a program's action builds its :class:`~samplehd.tasks.task.Task` (how many
  object arguments, whether it takes a set, what its value is) and how an executor dict parses; the
  constraints its instructions must satisfy are data, in the family's template file
  (``samplehd/language/templates/<family>.json``), checked by :mod:`samplehd.language.constraints`;
- **planner recipe**: whether the path ends holding the object (``places``) and where a moved object
  goes (``destination``: a table part, past a reference object, on a support's top or into its
  opening); :func:`samplehd.motion.planner.destination_candidates` reads it;
- **checker predicate**: ``check(judge, task)`` returns why the task is not fulfilled ("" when it is)
  and details for the report; :func:`samplehd.tasks.checker.check_success` runs it.

Adding a family is one new module in :mod:`samplehd.tasks.families` (it calls :func:`register_family`)
plus its template data.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, TypedDict

from samplehd.errors import PlanningError
from samplehd.world.layout import TABLE_PARTS

__all__ = [
    "DESTINATIONS",
    "RELATION_NAMES",
    "VALUE_KINDS",
    "ProgramTask",
    "SampleHdTask",
    "Task",
    "TaskFamily",
    "family_names",
    "family_of_program",
    "get_family",
    "parse_part",
    "parse_relation",
    "parse_task",
    "register_family",
]

RELATION_NAMES = ("left", "right", "front", "behind")
_RELATION_ALIASES = {
    "left": "left", "left_of": "left", "left of": "left", "to the left of": "left",
    "right": "right", "right_of": "right", "right of": "right", "to the right of": "right",
    "front": "front", "in_front_of": "front", "in front of": "front",
    "behind": "behind", "back": "behind", "behind_of": "behind",
}


# Where the planner puts a moved object down (None: it keeps holding it).
DESTINATIONS = ("table_part", "beside", "top", "opening")
# What a program's action value is.
VALUE_KINDS = ("part", "relation")


@dataclass(frozen=True)
class TaskFamily:
    """One task family.

    Attributes:
        name: the family's name (instructions, templates, episodes).
        order: place in :func:`family_names` (error messages list families in this order).
        arity: object arguments of the program's action (a set counts as one).
        takes_set: the action's one argument is a set of objects (sorted into ``Task.objects``).
        value: kind of the action's value ("part", "relation") or None.
        flat_token: the SAMPLE-HD flat program token of the family (None: not expressible flat).
        build: the task of an action from its objects (in argument order, or the sorted set) and value.
        parse: the task of an executor dict: (objects, subject, bracket parameter, relation) -> Task.
        program: the executor dict's ``(type, subject)`` of a task of this family.
        check: the success predicate: (judge, task) -> (reason, details); reason "" on success (the
            judge, :class:`samplehd.tasks.checker.Judge`, holds the measurements of the judged state).
        destination: where the planner puts a moved object (one of :data:`DESTINATIONS`; None: hold it).
        destination_part: the table part the moved objects must end in (None: none).
        support_of: the object that object ``obj`` must end on or in (-1: the table or the gripper).
        runs_as: the family whose program a task of this family is written as (remove runs as a place
            to the opposite part), with ``adopt`` turning such a task into one of this family.
        written_as: whether a flat program (SAMPLE-HD's tokens, action first) of the ``runs_as`` family
            stands for this family (remove: a place of everything on one table part); None: never.
    """

    name: str
    order: int
    arity: int
    build: Callable[[Sequence[int], Any], Task]
    parse: Callable[[list[int], Any, str | None, Any], Task]
    program: Callable[[Task], tuple[str, Any]]
    check: Callable[..., tuple[str, dict[str, Any]]]
    takes_set: bool = False
    value: str | None = None
    flat_token: str | None = None
    destination: str | None = None
    destination_part: Callable[[Task], str | None] = lambda task: None
    support_of: Callable[[Task, int], int] = lambda task, obj: -1
    runs_as: str | None = None
    adopt: Callable[[Task], Task] | None = None
    written_as: Callable[[Sequence[str]], bool] | None = None

    @property
    def places(self) -> bool:
        """Whether a path of this family puts the moved objects down (pick_up ends holding it)."""
        return self.destination is not None


_REGISTRY: dict[str, TaskFamily] = {}


def register_family(family: TaskFamily) -> TaskFamily:
    """Add a family to the registry (a family's module calls this once); returns it."""
    if family.destination is not None and family.destination not in DESTINATIONS:
        raise ValueError(f"family {family.name}: destination {family.destination!r}; valid: {DESTINATIONS}")
    if family.value is not None and family.value not in VALUE_KINDS:
        raise ValueError(f"family {family.name}: value {family.value!r}; valid: {VALUE_KINDS}")
    _REGISTRY[family.name] = family
    return family


def family_names() -> tuple[str, ...]:
    """Every registered family, in their declared order."""
    return tuple(sorted(_REGISTRY, key=lambda n: _REGISTRY[n].order))


def family_of_program(action: str, program: Sequence[str]) -> str:
    """The family a flat program whose action is of family ``action`` stands for: a family that runs
    as ``action`` and claims the program (:attr:`TaskFamily.written_as`), else ``action`` itself.

    Args:
        action: the family of the program's action (``place`` for a remove).
        program: the flat program's tokens, action first (``["place[back]", "scene", "filter_table[front]"]``).
    """
    for family in _REGISTRY.values():
        if family.runs_as == action and family.written_as is not None and family.written_as(program):
            return family.name
    return action


def get_family(name: str) -> TaskFamily:
    """The family called ``name``; raises PlanningError naming the valid ones."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise PlanningError(f"unknown task family {name!r}; valid: {', '.join(family_names())}") from None


class ProgramTask(TypedDict):
    """A task as the program executor writes it (the ``task`` of instruction files): the program's
    action, the moved objects, its subject (a table part, an object index, or None) and its relation."""

    type: str
    objects: list[int]
    subject: str | int | None
    relation: str | None


class SampleHdTask(TypedDict):
    """SAMPLE-HD's ``task`` entry (its ``preprocessing/sequence_data_preprocessing.py``)."""

    type: str
    object: list[int]
    subject: str | int | None


@dataclass(frozen=True)
class Task:
    """A task.

    Attributes:
        family: a registered family (:func:`samplehd.tasks.task.family_names`).
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

    def to_dict(self) -> dict[str, object]:
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

    def to_program_dict(self) -> ProgramTask:
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

    def to_sample_hd_task(self) -> SampleHdTask:
        """SAMPLE-HD's ``task`` entry ``{type, object, subject}`` (its
        ``preprocessing/sequence_data_preprocessing.py``): the family, the moved objects and the family's
        parameter as SAMPLE-HD names it (a part: the destination, or the cleared part of a remove; else
        the reference object)."""
        subject = self.part if get_family(self.family).value == "part" else self.reference
        return {"type": self.family, "object": list(self.objects), "subject": subject}


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


def parse_task(task: ProgramTask | Mapping[str, Any] | Task, family: str | None = None) -> Task:
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
