"""The grasp rule's touch test: the bodies' bounding spheres only rule out what the per-geom test would."""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import mujoco
import numpy as np
import pytest

from samplehd.motion.assist import GraspAssist, compile_scene_with_assist
from samplehd.motion.execute import initial_state
from samplehd.robot.controller import ControlConfig
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import object_qpos_addresses
from samplehd.world.robot_info import RobotInfo
from samplehd.world.seeding import scene_seed

_TOLERANCES = (0.0005, 0.005, 0.02, 0.1)


def _per_geom_candidates(assist: GraspAssist, data: mujoco.MjData, tolerance: float) -> set[int]:
    """The objects with a geom whose bounding sphere comes within ``tolerance`` of a geom's of each finger."""
    return {i for i, geoms in enumerate(assist.object_geoms) if len(geoms)
            and all((assist._gaps(data, fingers, geoms) < tolerance).any() for fingers in assist.finger_geoms)}


def _reference_touched(assist: GraspAssist, data: mujoco.MjData, tolerance: float) -> int:
    """The touch test as it was before the body spheres: every object's per-geom candidacy, then distances."""
    mujoco.mj_kinematics(assist.model, data)
    candidates = _per_geom_candidates(assist, data, tolerance)
    for i, geoms in enumerate(assist.object_geoms):
        if i in candidates and all(assist._near(data, fingers, geoms, tolerance) for fingers in assist.finger_geoms):
            return i
    return -1


@pytest.mark.parametrize("catalogue", ["procedural", "shop-vrb"])
def test_body_spheres_never_rule_out_a_touch(catalogue: str) -> None:
    scene = sample_scene(0, scene_seed(11, 0), SceneConfig(catalogue=catalogue)).scene
    n = len(scene.objects)
    model, data = compile_scene_with_assist(scene, robot_look="primitive")
    initial_state(model, data, ControlConfig())
    assist = GraspAssist(model, n)
    adr = object_qpos_addresses(model, n)
    tcp = RobotInfo.from_model(model, data).tcp_site
    rng = np.random.default_rng(3)
    rest = data.qpos.copy()
    near_states = touches = 0
    for _ in range(300):
        data.qpos[:] = rest
        mujoco.mj_kinematics(model, data)
        centre = data.site_xpos[tcp]
        i = int(rng.integers(n))
        # the object's origin at the fingers, a few centimetres off, turned at random
        data.qpos[adr[i]:adr[i] + 3] = centre + rng.normal(0.0, 0.03, 3)
        quat = rng.normal(size=4)
        data.qpos[adr[i] + 3:adr[i] + 7] = quat / np.linalg.norm(quat)
        for tolerance in _TOLERANCES:
            touched = assist.touched(data, tolerance=tolerance)
            assert touched == _reference_touched(assist, data, tolerance)
            touches += touched >= 0
            candidates = _per_geom_candidates(assist, data, tolerance)
            near_states += bool(candidates)
            assert candidates <= assist._objects_near(data, tolerance)
    assert near_states > 50 and touches > 20, "the states drawn should put objects between the fingers"
