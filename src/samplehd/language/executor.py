"""One executor for both program formats: CLEVR node lists and SAMPLE-HD flat token sequences.

Running a program on a scene gives a :class:`~samplehd.tasks.task.Task`: what to do, to which
objects, where (each action is a task family's, :mod:`samplehd.tasks.task`). See
:mod:`samplehd.language.programs` for both formats.

Example:
    >>> from samplehd.language.scene import parse_scene
    >>> def obj(name, colour, y, parts):
    ...     return {"name": name, "colour": colour, "material": "ceramic", "size": "small",
    ...             "table_part": parts, "3d_coords": [0.0, y, 0.8], "bbox": {"extents": [0.1, 0.1, 0.1]}}
    >>> scene = parse_scene({"objects": [obj("mug", "red", 0.2, ["right"]), obj("plate", "white", -0.2, ["left"])]})
    >>> execute("place[left] scene filter_colour[red] filter_name[mug]", scene).to_program_dict()
    {'type': 'place', 'objects': [0], 'subject': 'left', 'relation': None}
    >>> execute("place[left] scene filter_table[right]", scene).objects  # SAMPLE-HD's "remove right"
    (0,)
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from samplehd.errors import SamplehdError
from samplehd.language.programs import ACTION_FUNCTIONS, FLAT_FILTER, FLAT_TASK_TOKENS, NODE_FUNCTIONS
from samplehd.language.scene import Scene, SceneObject, parse_scene
from samplehd.tasks.task import Task, get_family
from samplehd.world.layout import TABLE_PARTS
from samplehd.world.relations import RELATIONS

__all__ = [
    "ProgramError",
    "execute",
    "execute_nodes",
    "execute_sequence",
    "parse_token",
]

Subject = str | int | None


class ProgramError(SamplehdError, ValueError):
    """A program is malformed or does not evaluate on the scene (e.g. ``unique`` of two objects)."""


def _filter(objects: Sequence[SceneObject], items: frozenset[int], kind: str, value: str) -> frozenset[int]:
    if kind == "table_part":
        return frozenset([i for i in items if value in objects[i].table_part])
    return frozenset([i for i in items if getattr(objects[i], kind) == value])


# Where an error is: a message prefix, or ("node", index, function) / ("token", index, token), formatted
# only when an error is raised (programs are executed for every generated instruction, errors are rare).
Where = str | tuple[str, int, str]


def _at(where: Where) -> str:
    return where if isinstance(where, str) else f"{where[0]} {where[1]} ({where[2]})"


def _check_part(value: str, where: Where) -> str:
    if value not in TABLE_PARTS:
        raise ProgramError(f"{_at(where)}: unknown table part {value!r}; valid: {', '.join(TABLE_PARTS)}")
    return value


def _check_relation(value: str, where: Where) -> str:
    if value not in RELATIONS:
        raise ProgramError(f"{_at(where)}: unknown relation {value!r}; valid: {', '.join(RELATIONS)}")
    return value


def _as_object(value: Any, where: Where) -> int:
    if isinstance(value, int):
        return value
    if isinstance(value, frozenset) and len(value) == 1:
        return next(iter(value))
    raise ProgramError(f"{_at(where)}: expected one object, got {_describe(value)}")


def _as_set(value: Any, where: Where) -> frozenset[int]:
    if isinstance(value, int):
        return frozenset((value,))
    if isinstance(value, frozenset):
        return value
    raise ProgramError(f"{_at(where)}: expected objects, got {_describe(value)}")


def _describe(value: Any) -> str:
    if isinstance(value, frozenset):
        return f"{len(value)} objects {sorted(value)}"
    return repr(value)


def _make_task(type_: str, groups: list[Any], value: str | None, where: Where) -> Task:
    """Build the task of an action (its family's) from its (object or set) arguments."""
    family = get_family(type_)
    if family.takes_set:
        if len(groups) != 1:
            raise ProgramError(f"{_at(where)}: {type_} takes one object set, got {len(groups)}")
        objs = tuple(sorted(_as_set(groups[0], where)))
        if not objs:
            raise ProgramError(f"{_at(where)}: {type_} of an empty set")
    else:
        if len(groups) != family.arity:
            raise ProgramError(f"{_at(where)}: {type_} takes {family.arity} objects, got {len(groups)}")
        objs = tuple(_as_object(g, where) for g in groups)
        if len(set(objs)) != len(objs):
            raise ProgramError(f"{_at(where)}: {type_} needs distinct objects, got {list(objs)}")
    if family.value == "part":
        value = _check_part(str(value), where)
    elif family.value == "relation":
        value = _check_relation(str(value), where)
    return family.build(objs, value)


def execute_nodes(program: Sequence[Mapping[str, Any]], scene: Scene) -> Task:
    """Run a CLEVR node-list program on a scene.

    Raises:
        ProgramError: a node is malformed or does not evaluate (the message names the node).
    """
    objects = scene.objects
    values: list[Any] = []
    task: Task | None = None
    for k, nd in enumerate(program):
        if not (type(nd) is dict or isinstance(nd, Mapping)) or "type" not in nd:
            raise ProgramError(f"node {k}: expected {{type, inputs, value_inputs}}, got {nd!r}")
        type_ = str(nd["type"])
        where = ("node", k, type_)
        arity = NODE_FUNCTIONS.get(type_)
        if arity is None:
            raise ProgramError(f"{_at(where)}: unknown function; valid: {', '.join(sorted(NODE_FUNCTIONS))}")
        inputs = list(nd.get("inputs", []))
        vals = [v if type(v) is str else str(v) for v in nd.get("value_inputs", [])]
        for i in inputs:
            if not isinstance(i, int) or not 0 <= i < k:
                raise ProgramError(f"{_at(where)}: inputs must be indices of earlier nodes, got {inputs}")
        if len(vals) != arity:
            raise ProgramError(f"{_at(where)}: takes {arity} value inputs, got {vals}")
        args = [values[i] for i in inputs]
        result: Any
        if type_ in ACTION_FUNCTIONS:
            if task is not None:
                raise ProgramError(f"{_at(where)}: a program has one action")
            task = _make_task(type_, args, vals[0] if vals else None, where)
            result = task
        elif type_ == "scene":
            result = frozenset(range(len(objects)))
        elif type_.startswith("filter_"):
            kind = _NODE_FILTER_OF[type_]
            if len(args) != 1:
                raise ProgramError(f"{_at(where)}: takes one input")
            if kind == "table_part":
                _check_part(vals[0], where)
            result = _filter(objects, _as_set(args[0], where), kind, vals[0])
        elif type_ == "unique":
            if len(args) != 1:
                raise ProgramError(f"{_at(where)}: takes one input")
            result = _as_object(args[0], where)
        elif type_ == "relate":
            if len(args) != 1:
                raise ProgramError(f"{_at(where)}: takes one input")
            rel = _check_relation(vals[0], where)
            result = frozenset(scene.relationships[rel][_as_object(args[0], where)])
        else:  # union, intersect
            if len(args) != 2:
                raise ProgramError(f"{_at(where)}: takes two inputs")
            a, b = (_as_set(x, where) for x in args)
            result = a | b if type_ == "union" else a & b
        values.append(result)
    if task is None:
        raise ProgramError("program has no action node (place, stack, put, ...)")
    if not isinstance(values[-1], Task):
        raise ProgramError(f"node {len(values) - 1}: the action must be the last node")
    return task


_NODE_FILTER_KIND = {
    "name": "filter_name",
    "colour": "filter_color",
    "material": "filter_material",
    "size": "filter_size",
    "table_part": "filter_table_part",
}
_NODE_FILTER_OF = {f: k for k, f in _NODE_FILTER_KIND.items()}
_FLAT_FILTER_KIND = {f: k for k, f in FLAT_FILTER.items()}
_TOKEN = re.compile(r"^([a-z_]+)(?:\[([^\[\]]+)\])?$")


_PARSED: dict[str, tuple[str, str | None]] = {}  # well-formed tokens seen (a program's tokens repeat a lot)


def parse_token(token: str) -> tuple[str, str | None]:
    """Split a flat token ``"filter_colour[red]"`` into ``("filter_colour", "red")``."""
    parsed = _PARSED.get(token)
    if parsed is not None:
        return parsed
    match = _TOKEN.match(token)
    if not match:
        raise ProgramError(f"malformed token {token!r}; expected name or name[value]")
    if len(_PARSED) > 4096:  # tokens made afresh again and again: start over
        _PARSED.clear()
    parsed = _PARSED[token] = (match.group(1), match.group(2))
    return parsed


def execute_sequence(program: str | Sequence[str], scene: Scene) -> Task:
    """Run a SAMPLE-HD flat program (a string of tokens or a token list) on a scene.

    Raises:
        ProgramError: a token is malformed or does not evaluate (the message names the token).
    """
    tokens = program.split() if isinstance(program, str) else list(program)
    if not tokens:
        raise ProgramError("empty program")
    action, value = parse_token(tokens[0])
    if action not in FLAT_TASK_TOKENS:
        raise ProgramError(f"token 0: unknown task {action!r}; valid: {', '.join(FLAT_TASK_TOKENS)}")
    if FLAT_TASK_TOKENS[action] != (value is not None):
        raise ProgramError(f"token 0: {action} {'needs' if FLAT_TASK_TOKENS[action] else 'takes no'} [value]")
    objects = scene.objects
    groups: list[frozenset[int]] = []
    for k, token in enumerate(tokens[1:], start=1):
        name, val = parse_token(token)
        where: Where = ("token", k, token)
        if name == "scene":
            groups.append(frozenset(range(len(objects))))
            continue
        if not groups:
            raise ProgramError(f"{_at(where)}: an object group must start with 'scene'")
        if name == "filter_relate":
            rel = _check_relation(str(val), where)
            groups[-1] = frozenset(scene.relationships[rel][_as_object(groups[-1], where)])
        elif name in _FLAT_FILTER_KIND and val is not None:
            kind = _FLAT_FILTER_KIND[name]
            if kind == "table_part":
                _check_part(val, where)
            groups[-1] = _filter(objects, groups[-1], kind, val)
        else:
            valid = ", ".join([*(f"{f}[v]" for f in FLAT_FILTER.values()), "filter_relate[r]", "scene"])
            raise ProgramError(f"{_at(where)}: unknown token; valid: {valid}")
    where = f"task {tokens[0]}"
    if action == "place":
        return _make_task("place", [frozenset().union(*groups)] if groups else [], value, where)
    return _make_task(action, list(groups), value, where)


_EXECUTORS: dict[str, Callable[[Any, Scene], Task]] = {"nodes": execute_nodes, "sequence": execute_sequence}


def execute(program: str | Sequence[str] | Sequence[Mapping[str, Any]], scene: Scene | Mapping[str, Any]) -> Task:
    """Run a program in either format on a scene and return its task.

    Args:
        program: a CLEVR node list, a flat token list, or a flat program string.
        scene: the scene to run on (a parsed :class:`Scene` or a scene dict).

    Raises:
        ProgramError: the program is malformed or does not evaluate on the scene.
        SceneError: ``scene`` is a malformed scene dict.
    """
    if not isinstance(scene, Scene):
        scene = parse_scene(scene)
    if isinstance(program, str):
        return _EXECUTORS["sequence"](program, scene)
    items = list(program)
    if items and all(isinstance(x, str) for x in items):
        return _EXECUTORS["sequence"](items, scene)
    return _EXECUTORS["nodes"](items, scene)
