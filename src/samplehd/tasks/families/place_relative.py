"""place_relative: put an object beside another ("Place the cup to the left of the plate")."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from samplehd.errors import PlanningError
from samplehd.fixedmath import dot
from samplehd.tasks.checker import Judge
from samplehd.tasks.task import Task, TaskFamily, parse_relation, register_family


def _check(j: Judge, t: Task) -> tuple[str, dict[str, float]]:
    """The object rests on the table, its offset from the reference along the scene's direction
    vector above ``relation_margin``."""
    reason = ""
    i, ref = t.objects[0], t.reference
    d = np.asarray(j.directions[t.direction], dtype=float)[:3]
    offset = float(dot(j.pos(i) - j.pos(ref), d))
    details = {"offset": offset}
    if r := j.resting(i):
        reason = r
    elif not j.on_table(i):
        reason = f"object {i} does not rest on the table"
    elif offset <= j.cfg.relation_margin:
        reason = f"object {i} is not {t.direction} of object {ref} (offset {offset * 1000:.0f} mm)"
    return reason, details


def _build(objects: Sequence[int], relation: Any) -> Task:
    return Task("place_relative", (objects[0],), reference=objects[1], direction=relation)


def _parse(objects: list[int], subject: Any, param: str | None, raw: Mapping[str, Any]) -> Task:
    direction: str | None = parse_relation(param) if param else None
    if raw.get("relation"):
        direction = parse_relation(raw["relation"])
    ref: int | None = None
    if isinstance(subject, dict):
        direction = parse_relation(subject.get("direction", direction))
        ref = int(subject["reference"])
    elif isinstance(subject, list | tuple):
        for v in subject:
            if isinstance(v, str) and not v.lstrip("-").isdigit():
                direction = parse_relation(v)
            else:
                ref = int(v)
    elif subject is not None:
        ref = int(subject)
    if ref is None and len(objects) == 2:
        ref = objects[1]
    if ref is None or direction is None:
        raise PlanningError(f"task place_relative needs a direction and a reference object, got {dict(raw)!r}")
    return Task("place_relative", (objects[0],), reference=ref, direction=direction)


FAMILY = register_family(TaskFamily(
    name="place_relative",
    order=5,
    arity=2,
    value="relation",
    flat_token="place_relative",
    build=_build,
    parse=_parse,
    program=lambda t: ("place_relative", t.reference),
    check=_check,
    destination="beside",
))
