"""Programs for instructions in two formats, and how references turn into them.

**CLEVR node list.** A topologically sorted list of nodes ``{"type", "inputs", "value_inputs"}``.
Functions: ``scene`` (all objects), ``filter_name``, ``filter_color``, ``filter_material``,
``filter_size``, ``filter_table_part`` (objects whose centre lies in that table part), ``unique``
(the single object of a set), ``relate`` (objects in a direction of one object), ``union``,
``intersect``, and the action terminals below. A unique reference is
``scene -> filter_* ... -> unique``; a relational one starts from its anchor:
``scene -> filter_* -> unique -> relate[left] -> filter_name[mug] -> unique``.

**Flat token sequence (SAMPLE-HD).** One task token, then object groups, each starting with
``scene`` and narrowed by filters applied in order: ``filter_name[v]``, ``filter_colour[v]``,
``filter_material[v]``, ``filter_size[v]``, ``filter_table[part]``, and ``filter_relate[r]``
(from the group's single object to the objects in direction ``r`` of it). Spelling is British, as
in SAMPLE-HD. ``filter_size`` is samplehd's addition. Per family:

==============  ==========================================  ===================================
family          flat program                                task
==============  ==========================================  ===================================
place           ``place[P] scene ... [scene ...]``          move the union of the groups to P
remove (P)      ``place[opposite(P)] scene filter_table[P]``  same as place (SAMPLE-HD's form)
stack           ``stack scene <top> scene <base>``          top on base
put             ``put scene <object> scene <container>``    object into container
pick_up         ``pick_up scene <object>``                  lift and hold
place_relative  ``place_relative[R] scene <X> scene <Y>``   X into direction R of Y
stack_three     ``stack_three scene <top> scene <middle>    middle on bottom, then top on middle
                scene <bottom>``
==============  ==========================================  ===================================

In node lists the terminals are ``place[P]`` (one set input), ``remove[P]`` (one set input: the
part's objects), ``stack``, ``put``, ``place_relative[R]`` (two object inputs), ``pick_up`` (one)
and ``stack_three`` (three object inputs: top, middle, bottom).
"""

from __future__ import annotations

from typing import TypedDict

from samplehd.language.descriptions import Description
from samplehd.tasks.task import family_names, get_family

__all__ = [
    "ACTION_FUNCTIONS",
    "FLAT_FILTER",
    "FLAT_TASK_TOKENS",
    "NODE_FILTER",
    "NODE_FUNCTIONS",
    "ProgramNode",
    "node",
    "reference_nodes",
    "reference_tokens",
]

NODE_FILTER = {
    "name": "filter_name",
    "colour": "filter_color",
    "material": "filter_material",
    "size": "filter_size",
    "table_part": "filter_table_part",
}
FLAT_FILTER = {
    "name": "filter_name",
    "colour": "filter_colour",
    "material": "filter_material",
    "size": "filter_size",
    "table_part": "filter_table",
}
# Action node functions (one per task family) -> number of value inputs they take.
ACTION_FUNCTIONS: dict[str, int] = {name: int(get_family(name).value is not None) for name in family_names()}
NODE_FUNCTIONS: dict[str, int] = {
    "scene": 0,
    **{f: 1 for f in NODE_FILTER.values()},
    "unique": 0,
    "relate": 1,
    "union": 0,
    "intersect": 0,
    **ACTION_FUNCTIONS,
}
# Flat task tokens -> whether they take a [value] (families without a flat form are written as another).
FLAT_TASK_TOKENS: dict[str, bool] = {
    f.flat_token: f.value is not None for f in map(get_family, family_names()) if f.flat_token is not None
}


class ProgramNode(TypedDict):
    """One node of a CLEVR node-list program (an instruction's ``program`` in ``instructions.json``).

    Attributes:
        type: the function (``scene``, ``filter_colour``, ``relate``, an action ...).
        inputs: indices of the earlier nodes whose outputs it takes.
        value_inputs: its literal arguments (a colour, a relation, a table part ...).
    """

    type: str
    inputs: list[int]
    value_inputs: list[str]


def node(type_: str, inputs: list[int] | None = None, value_inputs: list[str] | None = None) -> ProgramNode:
    """Return a CLEVR program node."""
    return {"type": type_, "inputs": list(inputs or []), "value_inputs": list(value_inputs or [])}


def reference_nodes(description: Description, offset: int = 0, unique: bool = True) -> list[ProgramNode]:
    """Return the CLEVR nodes that evaluate a description; the last node's output is the referent.

    Args:
        description: the description.
        offset: index the first returned node will have in the whole program.
        unique: end with ``unique`` (a single object) rather than the set.
    """
    if description.anchor is not None:
        nodes = reference_nodes(description.anchor, offset, unique=True)
        nodes.append(node("relate", [offset + len(nodes) - 1], [str(description.relation)]))
    else:
        nodes = [node("scene")]
    for kind, value in description.filters:
        nodes.append(node(NODE_FILTER[kind], [offset + len(nodes) - 1], [value]))
    if unique:
        nodes.append(node("unique", [offset + len(nodes) - 1]))
    return nodes


def reference_tokens(description: Description) -> list[str]:
    """Return the flat-format tokens of one object group: ``scene filter_colour[red] ...``."""
    if description.anchor is not None:
        tokens = reference_tokens(description.anchor)
        tokens.append(f"filter_relate[{description.relation}]")
    else:
        tokens = ["scene"]
    tokens += [f"{FLAT_FILTER[kind]}[{value}]" for kind, value in description.filters]
    return tokens
