"""A SHOP-VRB scene shared by the world tests: convex hulls resting on the table, two of them touching."""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import mujoco
import pytest

from samplehd.catalogue import ObjectInstance
from samplehd.scene.spec import SceneObject, SceneSpec, compile_scene
from samplehd.world.bodies import SceneBodies
from samplehd.world.robot_info import RobotInfo

TABLE = 0.75  # [m]
UP = (1.0, 0.0, 0.0, 0.0)
MUG = ObjectInstance("mug", "shopvrb1", "red", "ceramic", "medium")


@pytest.fixture(scope="module")
def shop_scene() -> tuple[mujoco.MjModel, mujoco.MjData, SceneBodies, RobotInfo]:
    """Three SHOP-VRB shapes (convex hulls) resting on the table, two of them touching."""
    objs = (
        SceneObject(MUG, (0.05, -0.15, TABLE), UP),
        SceneObject(ObjectInstance("bowl", "shopvrb1", "white", "ceramic", "medium"), (0.05, 0.05, TABLE), UP),
        SceneObject(ObjectInstance("food_box", "shopvrb1", "yellow", "plastic", "small"), (0.12, 0.05, TABLE), UP),
    )
    model, data = compile_scene(SceneSpec(index=0, seed=0, objects=objs), robot_look="primitive")
    return model, data, SceneBodies(model, len(objs)), RobotInfo.from_model(model, data)

