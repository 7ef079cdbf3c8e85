"""Where the robot lives in a compiled world: qpos/dof addresses, TCP site, finger joints, and how
the fingers' closing direction sits in the TCP frame."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from samplehd.errors import PlanningError
from samplehd.fixedmath import dot, matmul, norm
from samplehd.robot.constants import GRIPPER_FINGER_JOINTS, GRIPPER_STROKE, JOINT_NAMES, ROBOT_BODY

__all__ = ["RobotInfo"]


@dataclass(frozen=True, eq=False)
class RobotInfo:
    """Addresses of the arm and gripper in a compiled model.

    Attributes:
        arm_qpos: qpos addresses of the six arm joints.
        arm_dof: dof addresses of the six arm joints.
        finger_qpos: qpos addresses of the two finger joints.
        finger_range: (2, 2) joint ranges of the finger joints.
        tcp_site: id of the ``tcp`` site.
        base_pos: world position of the robot base frame [m].
        base_rot: world orientation of the robot base frame (3×3).
        finger_axis: unit vector in the TCP frame along which the fingers close.
        finger_open_sign: +1 when increasing finger joint values open the gripper, else -1.
        finger_depth: how far the fingertips reach beyond the TCP along the approach axis [m].
    """

    arm_qpos: np.ndarray
    arm_dof: np.ndarray
    finger_qpos: np.ndarray
    finger_range: np.ndarray
    tcp_site: int
    base_pos: np.ndarray
    base_rot: np.ndarray
    finger_axis: np.ndarray
    finger_open_sign: float
    finger_depth: float

    @classmethod
    def from_model(cls, model: mujoco.MjModel, data: mujoco.MjData | None = None) -> RobotInfo:
        """Read the addresses; raises PlanningError if the model has no robot."""
        ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in JOINT_NAMES]
        if min(ids) < 0:
            raise PlanningError("the world has no UR5e (build it with WorldConfig(with_robot=True))")
        fids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in GRIPPER_FINGER_JOINTS]
        tcp = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "tcp")
        base = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, ROBOT_BODY)
        if min(fids) < 0 or tcp < 0 or base < 0:
            raise PlanningError("the robot model lacks finger joints, the tcp site or robot_base")
        d = mujoco.MjData(model) if data is None else data
        if data is None:
            mujoco.mj_forward(model, d)
        tcp_rot = d.site_xmat[tcp].reshape(3, 3)
        # Direction of finger 0's travel, in the TCP frame, at a slightly opened state.
        j0 = fids[0]
        axis_world = matmul(d.xmat[model.jnt_bodyid[j0]].reshape(3, 3), model.jnt_axis[j0])
        axis_tcp = matmul(tcp_rot.T, axis_world)
        axis_tcp[2] = 0.0
        axis_tcp /= max(norm(axis_tcp), 1e-9)
        # Does finger 0 move away from the TCP (opening) as its joint increases?
        rel = d.xpos[model.jnt_bodyid[j0]] - d.site_xpos[tcp]
        open_sign = 1.0 if dot(axis_world, rel) >= 0 else -1.0
        depth = 0.0
        tcp_pos = d.site_xpos[tcp]
        for fj in fids:
            fb = model.jnt_bodyid[fj]
            for g in np.flatnonzero(model.geom_bodyid == fb):
                if not (model.geom_contype[g] or model.geom_conaffinity[g]):
                    continue
                c, h = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
                signs = np.array([[a, b, e] for a in (-1, 1) for b in (-1, 1) for e in (-1, 1)], float)
                pts = matmul(c + signs * h, d.geom_xmat[g].reshape(3, 3).T) + d.geom_xpos[g]
                depth = max(depth, float(np.max(matmul(pts - tcp_pos, tcp_rot[:, 2]))))
        return cls(
            arm_qpos=np.array([model.jnt_qposadr[j] for j in ids]),
            arm_dof=np.array([model.jnt_dofadr[j] for j in ids]),
            finger_qpos=np.array([model.jnt_qposadr[j] for j in fids]),
            finger_range=np.array([model.jnt_range[j] for j in fids]),
            tcp_site=tcp,
            base_pos=d.xpos[base].copy(),
            base_rot=d.xmat[base].reshape(3, 3).copy(),
            finger_axis=axis_tcp,
            finger_open_sign=open_sign,
            finger_depth=depth,
        )

    def finger_qpos_for(self, opening: float) -> np.ndarray:
        """Finger joint values for a finger opening [m] (linear over each joint's range)."""
        frac = float(np.clip(opening / GRIPPER_STROKE, 0.0, 1.0))
        lo, hi = self.finger_range[:, 0], self.finger_range[:, 1]
        return np.where(np.full(2, self.finger_open_sign > 0), lo + frac * (hi - lo), hi - frac * (hi - lo))

    def world_to_base(self, pose: np.ndarray) -> np.ndarray:
        """A world 4×4 pose in the robot base frame."""
        t = np.eye(4)
        t[:3, :3] = matmul(self.base_rot.T, pose[:3, :3])
        t[:3, 3] = matmul(self.base_rot.T, pose[:3, 3] - self.base_pos)
        return t

    def base_to_world(self, pose: np.ndarray) -> np.ndarray:
        """A base-frame 4×4 pose in the world."""
        t = np.eye(4)
        t[:3, :3] = matmul(self.base_rot, pose[:3, :3])
        t[:3, 3] = matmul(self.base_rot, pose[:3, 3]) + self.base_pos
        return t
