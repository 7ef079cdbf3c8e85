"""A long object set on a support's top is laid along the top where, as it is turned, it overhangs it
(``destination_candidates(align_on_top=True)``, the oracle's): a shop-vrb fork (26 cm) across a baking
tray (19 cm of floor across) comes down on the rim; along it, on the floor."""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import math

import numpy as np
import pytest

from samplehd.catalogue import ObjectInstance
from samplehd.motion.execute import scene_facts
from samplehd.motion.planner import destination_candidates, release_height, top_turn
from samplehd.scene.spec import SceneObject, SceneSpec, compile_scene
from samplehd.tasks.task import Task
from samplehd.world.bodies import SceneBodies, object_footprint, object_pose
from samplehd.world.collision import CollisionChecker
from samplehd.world.planner_config import PlannerConfig
from samplehd.world.robot_info import RobotInfo

TABLE = 0.75  # [m]
TASK = Task("stack", (0,), reference=1)  # the fork (0) on top of the tray (1)


def _yaw(angle: float) -> tuple[float, float, float, float]:
    return (math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2))


@pytest.fixture(scope="module", params=[0.0, 0.5])
def scene(request):
    """The tray turned by the parameter [rad], the fork across it (along y), away from it on the table."""
    tray_yaw = request.param
    objs = (
        SceneObject(ObjectInstance("fork", "shopvrb1", "red", "metal", "medium"), (0.05, 0.3, TABLE),
                    _yaw(tray_yaw + math.pi / 2)),
        SceneObject(ObjectInstance("baking_tray", "shopvrb1", "white", "metal", "medium"), (0.15, -0.15, TABLE),
                    _yaw(tray_yaw)),
    )
    spec = SceneSpec(index=0, seed=0, objects=objs)
    model, data = compile_scene(spec, robot_look="primitive")
    return model, data, SceneBodies(model, len(objs)), scene_facts(spec)


def _inside_top(data, bodies, facts, xy: np.ndarray, yaw: float) -> bool:
    """Whether the fork's footprint, its origin at ``xy`` turned by ``yaw``, lies inside the tray's top."""
    _, rot, half = object_footprint(data, bodies, 0, facts[0])
    c, s = math.cos(yaw), math.sin(yaw)
    turned = np.array([[c, -s], [s, c]]) @ rot
    t_tray = object_pose(data, bodies, 1)
    centre = xy + turned @ np.asarray(facts[0].footprint_center)
    in_tray = t_tray[:2, :2].T @ np.column_stack([turned, centre - t_tray[:2, 3]])
    reach = np.abs(in_tray[:, :2]) @ half + np.abs(in_tray[:, 2] - np.asarray(facts[1].top.center))
    return bool(np.all(reach <= np.asarray(facts[1].top.half_extents) + 1e-9))


def _rest_height(model, data, bodies, xy: np.ndarray, yaw: float) -> float:
    """Where the fork's frame comes to rest at ``xy`` turned by ``yaw``: MuJoCo's collisions, probed down."""
    checker = CollisionChecker(model, data, bodies, RobotInfo.from_model(model, data))
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ object_pose(data, bodies, 0)[:3, :3]
    return release_height(checker, bodies, 0, rot, xy, TABLE + 0.15, TABLE - 0.001, step=0.0005)


def test_a_fork_across_a_tray_is_turned_along_it_and_rests_on_its_floor(scene) -> None:
    model, data, bodies, facts = scene
    rng = np.random.default_rng(0)
    (xy0, yaw0), = destination_candidates(data, bodies, facts, 0, TASK, rng, PlannerConfig())
    (xy1, yaw1), = destination_candidates(data, bodies, facts, 0, TASK, rng, PlannerConfig(), align_on_top=True)
    assert yaw0 == 0.0 and not _inside_top(data, bodies, facts, xy0, yaw0)
    assert abs(abs(yaw1) - math.pi / 2) < 1e-6 and _inside_top(data, bodies, facts, xy1, yaw1)
    assert np.allclose(xy0, xy1)  # the fork's footprint is centred on its origin: on the top's centre
    across, along = _rest_height(model, data, bodies, xy0, yaw0), _rest_height(model, data, bodies, xy1, yaw1)
    floor = TABLE + facts[1].top.height
    assert along < floor + 0.005 < across - 0.01  # along: on the floor; across: on the rim, 1 cm higher or more


def test_an_object_that_fits_as_it_is_or_neither_way_is_not_turned(scene) -> None:
    model, data, bodies, facts = scene
    _, rot, half = object_footprint(data, bodies, 0, facts[0])
    t_tray = object_pose(data, bodies, 1)
    along = np.array([[0.0, -1.0], [1.0, 0.0]]).T @ rot  # the fork turned back along the tray
    assert top_turn(along, half, t_tray, facts[1]) == 0.0
    assert top_turn(rot, half * 2.0, t_tray, facts[1]) == 0.0  # 52 cm long: fits neither way
    assert abs(abs(top_turn(rot, half, t_tray, facts[1])) - math.pi / 2) < 1e-6
    assert top_turn(along, half, t_tray, None) == 0.0  # a support without facts
