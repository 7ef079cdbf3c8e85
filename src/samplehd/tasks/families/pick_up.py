"""pick_up: lift an object and hold it ("Pick up the red mug")."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from samplehd.tasks.checker import Judge, welded
from samplehd.tasks.task import Task, TaskFamily, register_family
from samplehd.world.bodies import object_world_box


def _check(j: Judge, t: Task) -> tuple[str, dict[str, float]]:
    """The object's bottom is ``lift_height`` above the table, it touches a finger (or hangs in the
    grasp assist's weld) and nothing but the robot."""
    reason = ""
    bodies = j.b
    i = t.objects[0]
    box = object_world_box(j.model, j.end, bodies, i)
    lift = float(box.lo[2] - j.layout.table_height)
    details = {"lift": lift}
    fingers = {b for b in bodies.gripper_bodies if b in bodies.robot_bodies}
    touched = {b for b in fingers if j.touching(i, b)}
    others = {o for (a, b2) in j.contacts for o in (a, b2) if int(bodies.object_body[i]) in (a, b2)} - fingers
    others.discard(int(bodies.object_body[i]))
    if lift < j.cfg.lift_height:
        reason = f"object {i} is only {lift * 1000:.0f} mm above the table"
    elif not touched and not welded(j.model, j.end, i):
        reason = f"object {i} is not held by the gripper"
    elif others - bodies.robot_bodies:
        reason = f"object {i} rests on something besides the gripper"
    return reason, details


def _build(objects: Sequence[int], value: Any) -> Task:
    return Task("pick_up", (objects[0],))


def _parse(objects: list[int], subject: Any, param: str | None, raw: Mapping[str, Any]) -> Task:
    return Task("pick_up", (objects[0],))


FAMILY = register_family(TaskFamily(
    name="pick_up",
    order=4,
    arity=1,
    flat_token="pick_up",
    build=_build,
    parse=_parse,
    program=lambda t: ("pick_up", None),
    check=_check,
))
