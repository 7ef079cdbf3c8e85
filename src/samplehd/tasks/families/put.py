"""put: put an object into a container ("Put the spoon into the bowl")."""

from __future__ import annotations

from samplehd.tasks.checker import Judge
from samplehd.tasks.families.stack import build_on, parse_on
from samplehd.tasks.task import Task, TaskFamily, register_family
from samplehd.world.bodies import object_world_box


def _check(j: Judge, t: Task) -> tuple[str, dict[str, float]]:
    """The object rests inside the container's footprint (shrunk by ``container_margin``), its
    bottom below the container's rim."""
    reason = ""
    i, c = t.objects[0], t.reference
    cb = object_world_box(j.model, j.end, j.b, c)
    ob = object_world_box(j.model, j.end, j.b, i)
    details = {"object_bottom": float(ob.lo[2]), "rim": float(cb.hi[2])}
    if r := j.resting(i):
        reason = r
    elif not cb.contains_xy(j.pos(i), j.cfg.container_margin):
        reason = f"object {i} is not inside the footprint of container {c}"
    elif ob.lo[2] > cb.hi[2] + j.cfg.rim_tolerance:
        reason = f"object {i} is not below the rim of container {c}"
    return reason, details


FAMILY = register_family(TaskFamily(
    name="put",
    order=3,
    arity=2,
    flat_token="put",
    build=build_on("put"),
    parse=parse_on("put"),
    program=lambda t: ("put", t.reference),
    check=_check,
    destination="opening",
    support_of=lambda t, obj: t.reference,
))
