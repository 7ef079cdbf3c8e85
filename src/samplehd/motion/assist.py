"""Grasp assist: a weld between the gripper and the object it holds, switched on once both finger
pads touch the object after CloseGripper and off when OpenGripper starts.

Pads pinching a thin rim or a handle far from the object's centre of mass (bowls, trays, pans) make
line or point contacts in MuJoCo that cannot carry the object's torque, so the object pivots out of
the fingers although a real rubber pad would hold it. SAMPLE-HD's Unity paths attach the object in
the same situation. The weld keeps the object exactly where the fingers closed on it; the fingers
still close on it physically and the safety monitor still watches every contact.

The welds are added at model-building time (inactive, one per scene object) by
:func:`add_grasp_welds`; :func:`compile_scene_with_assist` compiles a scene with them. They change no
state dimension (nq, nv, na), so episodes replay on models compiled with or without them.
"""

from __future__ import annotations

import mujoco
import numpy as np

from samplehd.fixedmath import matmul
from samplehd.physics import wake_all
from samplehd.scene.spec import SceneSpec
from samplehd.scene.world import PlacedObject, build_world, reset_robot_home
from samplehd.world.bodies import object_body_name

__all__ = ["GRASP_WELD_PREFIX", "GraspAssist", "add_grasp_welds", "compile_scene_with_assist"]

GRASP_WELD_PREFIX = "grasp_weld_"
_GRIPPER_BODY = "robot_gripper"


def add_grasp_welds(spec: mujoco.MjSpec, num_objects: int) -> None:
    """Add one inactive weld ``grasp_weld_{i}`` between the gripper and each object body."""
    for i in range(num_objects):
        eq = spec.add_equality()
        eq.name = f"{GRASP_WELD_PREFIX}{i}"
        eq.type = mujoco.mjtEq.mjEQ_WELD
        eq.objtype = mujoco.mjtObj.mjOBJ_BODY
        eq.name1 = _GRIPPER_BODY
        eq.name2 = object_body_name(i)
        eq.active = False
        eq.solref = [0.01, 1.0]


def compile_scene_with_assist(scene: SceneSpec, timestep: float = 0.002) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Like ``samplehd.scene.spec.compile_scene`` (arm at home, gripper open), with the grasp welds added."""

    placed = [PlacedObject(o.instance, tuple(o.pos), tuple(o.quat)) for o in scene.objects]
    spec = build_world(placed, scene.world_config(timestep))
    add_grasp_welds(spec, len(scene.objects))
    model = spec.compile()
    data = mujoco.MjData(model)
    reset_robot_home(model, data)
    mujoco.mj_forward(model, data)
    return model, data


class GraspAssist:
    """Switches the grasp welds of a compiled model.

    Args:
        model: compiled scene (welds missing: the assist does nothing).
        num_objects: number of scene objects.
    """

    def __init__(self, model: mujoco.MjModel, num_objects: int) -> None:
        self.model = model
        self.gripper = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, _GRIPPER_BODY)
        self.eq = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, f"{GRASP_WELD_PREFIX}{i}")
                   for i in range(num_objects)]
        self.active = -1

    @property
    def available(self) -> bool:
        """Whether the model has the welds."""
        return self.gripper >= 0 and all(e >= 0 for e in self.eq)

    def attach(self, data: mujoco.MjData, i: int) -> bool:
        """Weld object ``i`` to the gripper at their current relative pose; False if unavailable."""
        if not self.available:
            return False
        m = self.model
        b = m.body(object_body_name(i)).id
        rg = data.xmat[self.gripper].reshape(3, 3)
        rel_pos = matmul(rg.T, data.xpos[b] - data.xpos[self.gripper])
        qg_inv = np.empty(4)
        mujoco.mju_negQuat(qg_inv, data.xquat[self.gripper])
        rel_quat = np.empty(4)
        mujoco.mju_mulQuat(rel_quat, qg_inv, data.xquat[b])
        e = self.eq[i]
        # Weld data: anchor (3), relative pose of body2 in body1's frame (pos 3, quat 4), torque scale.
        m.eq_data[e, 0:3] = 0.0
        m.eq_data[e, 3:6] = rel_pos
        m.eq_data[e, 6:10] = rel_quat
        m.eq_data[e, 10] = 1.0
        data.eq_active[e] = 1
        self.active = i
        return True

    def release(self, data: mujoco.MjData) -> None:
        """Switch every grasp weld off."""
        if self.available:
            for e in self.eq:
                data.eq_active[e] = 0
            wake_all(data)
        self.active = -1
