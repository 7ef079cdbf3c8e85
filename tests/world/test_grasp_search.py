"""choose_grasps: a search made again from the same bytes is the same search; a fitted pinch on a sloped brim."""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import dataclasses

import pytest

from samplehd.catalogue import ObjectInstance, object_facts
from samplehd.robot.constants import HOME_QPOS
from samplehd.scene.spec import SceneObject, SceneSpec, compile_scene
from samplehd.world import grasps
from samplehd.world.bodies import SceneBodies
from samplehd.world.collision import CollisionChecker
from samplehd.world.planner_config import PlannerConfig
from samplehd.world.robot_info import RobotInfo

MUG = ObjectInstance("mug", "shopvrb1", "red", "ceramic", "medium")  # the shop_scene fixture's object 0
TABLE = 0.75  # [m]
UP = (1.0, 0.0, 0.0, 0.0)


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


def test_a_fitted_pinch_meets_a_sloped_brim_with_both_pads_at_once() -> None:
    """The procedural small soup plate's brim slopes 74° from vertical: around the rim site's nominal wall
    the inner pad meets the brim long before the outer pad meets the lip (it pushes the plate away);
    with ``fit_pinch`` both pads are as far from it, and the grasp's width is what they pinch."""
    plate = ObjectInstance("plate", "soup", "blue", "plastic", "small")
    spec = SceneSpec(index=0, seed=0, objects=(SceneObject(plate, (0.3, 0.1, TABLE), UP),))
    model, data = compile_scene(spec, robot_look="primitive")
    bodies, robot = SceneBodies(model, 1), RobotInfo.from_model(model, data)
    checker = CollisionChecker(model, data, bodies, robot)
    facts = object_facts(plate)
    gaps = {}
    for fit in (False, True):
        (_, gp), *_ = grasps.choose_grasps(model, data, bodies, robot, checker, 0, facts, HOME_QPOS.copy(),
                                           PlannerConfig(), fit_pinch=fit)
        assert gp.grasp.name == "rim"
        gaps[fit] = grasps.pinch_gaps(model, data, bodies, 0, robot.base_to_world(gp.tcp_grasp), robot,
                                      gp.grasp.opening)
        width = gp.grasp.width
    assert abs(gaps[False][0] - gaps[False][1]) > 0.01
    assert abs(gaps[True][0] - gaps[True][1]) <= 0.0005
    assert width == pytest.approx(gp.grasp.opening - sum(gaps[True]), abs=0.001) and width > 0.01
