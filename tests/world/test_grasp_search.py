"""choose_grasps's memo: a search made again from the same bytes is the same search."""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import dataclasses

from samplehd.catalogue import ObjectInstance, object_facts
from samplehd.robot.constants import HOME_QPOS
from samplehd.world import grasps
from samplehd.world.collision import CollisionChecker
from samplehd.world.planner_config import PlannerConfig

MUG = ObjectInstance("mug", "shopvrb1", "red", "ceramic", "medium")  # the shop_scene fixture's object 0


def test_a_remembered_grasp_search_is_the_search(shop_scene) -> None:
    """choose_grasps with a memo: the first call searches, a call with the same bytes gets an equal copy
    (changing it changes nothing kept), and another state searches again."""
    model, data, bodies, robot = shop_scene
    checker = CollisionChecker(model, data, bodies, robot)
    facts = object_facts(MUG)
    args = (model, data, bodies, robot, checker, 0, facts, HOME_QPOS.copy(), PlannerConfig())
    plain = grasps.choose_grasps(*args)
    assert plain
    kept = len(grasps._SEARCHES)
    first = grasps.choose_grasps(*args, memo="the mug scene")
    assert len(grasps._SEARCHES) == kept + 1
    first[0][1].q_grasp[:] = 0.0  # a caller's change stays with the caller
    again = grasps.choose_grasps(*args, memo="the mug scene")
    assert len(grasps._SEARCHES) == kept + 1
    for a, b in zip(plain, again, strict=True):
        assert a[0] == b[0] and a[1].grasp == b[1].grasp
        for f in dataclasses.fields(a[1]):
            if f.name != "grasp":
                assert getattr(a[1], f.name).tobytes() == getattr(b[1], f.name).tobytes()
    other = HOME_QPOS.copy()
    other[5] += 0.5
    grasps.choose_grasps(model, data, bodies, robot, checker, 0, facts, other, PlannerConfig(), memo="the mug scene")
    assert len(grasps._SEARCHES) == kept + 2
