"""affordances.graspable in the scene annotation: the class is graspable AND the ground-truth planner
finds a top-down grasp from home in this scene (world.grasps.graspable_in_scene)."""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
from typing import Any

import mujoco
import pytest

from samplehd.catalogue import ObjectInstance, object_facts
from samplehd.scene.annotate import annotate_scene
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import SceneObject, SceneSpec, compile_scene
from samplehd.world.bodies import SceneBodies
from samplehd.world.collision import CollisionChecker
from samplehd.world.grasps import choose_grasps, graspable_in_scene
from samplehd.world.layout import LAYOUT
from samplehd.world.planner_config import PlannerConfig
from samplehd.world.robot_info import RobotInfo
from samplehd.world.seeding import scene_seed

TABLE = LAYOUT.table_height
UP = (1.0, 0.0, 0.0, 0.0)


def _grasps(model: mujoco.MjModel, data: mujoco.MjData, facts: list[Any], i: int) -> list[Any]:
    """choose_grasps of object i from the arm's state in ``data``, with the default planner settings."""
    robot = RobotInfo.from_model(model, data)
    bodies = SceneBodies(model, len(facts))
    checker = CollisionChecker(model, data, bodies, robot)
    seed = data.qpos[robot.arm_qpos].copy()
    return choose_grasps(model, data, bodies, robot, checker, i, facts[i], seed, PlannerConfig())


def _annotate(scene: SceneSpec, camera: str) -> tuple[mujoco.MjModel, mujoco.MjData, dict[str, Any]]:
    model, data = compile_scene(scene)
    return model, data, annotate_scene(scene, model, data, 64, 36, camera=camera)


@pytest.mark.parametrize("index", [0, 1, 2])
def test_annotated_graspable_objects_have_a_planner_grasp(index: int) -> None:
    scene = sample_scene(index, scene_seed(11, index)).scene
    model, data, ann = _annotate(scene, "scene")
    facts = [object_facts(o.instance) for o in scene.objects]
    flags = [bool(o["affordances"]["graspable"]) for o in ann["objects"]]
    assert len(flags) == len(scene.objects) and any(flags)
    for i, f in enumerate(facts):
        has_grasp = bool(_grasps(model, data, facts, i))
        if flags[i]:
            assert has_grasp, f"object {i} ({scene.objects[i].instance.class_name}) is annotated graspable"
        else:
            # Not graspable: the class is not, or the planner finds no grasp in this scene.
            assert not (f.affordances.graspable and has_grasp), f"object {i} has a grasp but is not graspable"
    assert flags == [f.affordances.graspable and ok for f, ok in
                     zip(facts, graspable_in_scene(model, data, facts), strict=True)]


@pytest.fixture(scope="module")
def hand_built() -> tuple[SceneSpec, mujoco.MjModel, mujoco.MjData, dict[str, Any]]:
    """Three cans of a graspable class: far out of reach, against the robot base, and in reach."""
    can = ("soda_can", "standard")
    objs = (
        SceneObject(ObjectInstance(*can, "red", "metal", "medium"), (0.45, 0.62, TABLE), UP),
        SceneObject(ObjectInstance(*can, "blue", "metal", "medium"), (-0.27, 0.0, TABLE), UP),
        SceneObject(ObjectInstance(*can, "green", "metal", "medium"), (0.05, -0.15, TABLE), UP),
    )
    for o in objs:
        o.instance.validate()
    scene = SceneSpec(index=0, seed=0, objects=objs)
    model, data, ann = _annotate(scene, "operator")
    return scene, model, data, ann


def test_object_out_of_reach_or_at_the_base_is_not_graspable(hand_built: tuple[Any, ...]) -> None:
    scene, model, data, ann = hand_built
    facts = [object_facts(o.instance) for o in scene.objects]
    assert all(f.affordances.graspable for f in facts)  # the class is graspable
    # Reach of the positions, for the record: the far can is beyond the arm's reach annulus.
    assert not LAYOUT.in_reach(scene.objects[0].pos[:2])
    assert not LAYOUT.in_reach(scene.objects[1].pos[:2])
    assert LAYOUT.in_reach(scene.objects[2].pos[:2])
    flags = [o["affordances"]["graspable"] for o in ann["objects"]]
    assert flags == [False, False, True]
    assert graspable_in_scene(model, data, facts) == [False, False, True]
    assert not _grasps(model, data, facts, 0)
    assert not _grasps(model, data, facts, 1)
    assert _grasps(model, data, facts, 2)


def test_annotation_leaves_the_state_untouched(hand_built: tuple[Any, ...]) -> None:
    scene, model, data, _ = hand_built
    qpos = data.qpos.copy()
    again = annotate_scene(scene, model, data, 64, 36, camera="operator")
    assert (data.qpos == qpos).all()
    assert [o["affordances"]["graspable"] for o in again["objects"]] == [False, False, True]


def test_board_in_reach_without_a_top_down_grasp_is_not_graspable() -> None:
    # A rectangular chopping board in reach, alone: its class is graspable (by the edge), but the
    # ground-truth planner only grasps from above, and the board is too wide for the fingers.
    objs = (SceneObject(ObjectInstance("chopping_board", "rectangular", "brown", "wooden", "medium"),
                        (0.12, 0.26, TABLE), UP),)
    scene = SceneSpec(index=0, seed=0, objects=objs)
    model, data, ann = _annotate(scene, "operator")
    facts = [object_facts(o.instance) for o in objs]
    assert facts[0].affordances.graspable
    assert ann["objects"][0]["affordances"]["graspable"] is False
    assert not _grasps(model, data, facts, 0)
