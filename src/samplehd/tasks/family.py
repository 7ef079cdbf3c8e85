"""The registry of task families: each family declared once, in its own module of
:mod:`samplehd.tasks.families`.

A :class:`TaskFamily` says everything the stages need to know about one kind of instruction:

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

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from samplehd.errors import PlanningError

if TYPE_CHECKING:
    from samplehd.tasks.judge import Judge
    from samplehd.tasks.task import Task

__all__ = ["DESTINATIONS", "VALUE_KINDS", "TaskFamily", "family_names", "get_family", "register_family"]

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
        check: the success predicate: (judge, task) -> (reason, details); reason "" on success.
        destination: where the planner puts a moved object (one of :data:`DESTINATIONS`; None: hold it).
        destination_part: the table part the moved objects must end in (None: none).
        support_of: the object that object ``obj`` must end on or in (-1: the table or the gripper).
        runs_as: the family whose program a task of this family is written as (remove runs as a place
            to the opposite part), with ``adopt`` turning such a task into one of this family.
    """

    name: str
    order: int
    arity: int
    build: Callable[[Sequence[int], Any], Task]
    parse: Callable[[list[int], Any, str | None, Any], Task]
    program: Callable[[Task], tuple[str, Any]]
    check: Callable[[Judge, Task], tuple[str, dict[str, Any]]]
    takes_set: bool = False
    value: str | None = None
    flat_token: str | None = None
    destination: str | None = None
    destination_part: Callable[[Task], str | None] = lambda task: None
    support_of: Callable[[Task, int], int] = lambda task, obj: -1
    runs_as: str | None = None
    adopt: Callable[[Task], Task] | None = None

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


def get_family(name: str) -> TaskFamily:
    """The family called ``name``; raises PlanningError naming the valid ones."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise PlanningError(f"unknown task family {name!r}; valid: {', '.join(family_names())}") from None
