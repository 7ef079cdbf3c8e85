"""Records one :data:`~samplehd.record.episode.FRAME_FIELDS` frame per control step.

A frame pairs the state observed at the start of a control step with the command issued in that
step (joint targets, gripper command and the SAMPLE-HD steering vector that produces the same TCP
motion), as a policy would see and act. The last frame holds the final state with a hold command.
"""

from __future__ import annotations

import mujoco
import numpy as np

from samplehd.record.episode import FRAME_FIELDS

__all__ = ["FrameRecorder", "grasped_object", "steering_from_targets"]


def _rotvec(r: np.ndarray) -> np.ndarray:
    """Rotation vector of a rotation matrix [rad]."""
    cos = float(np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0))
    ang = float(np.arccos(cos))
    if ang < 1e-9:
        return np.zeros(3)
    v = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    s = float(np.linalg.norm(v))
    if s < 1e-9:
        w, vec = np.linalg.eigh((r + r.T) / 2)
        return vec[:, int(np.argmax(w))] * ang
    return v / s * ang


def steering_from_targets(
    pose_now: np.ndarray, pose_next: np.ndarray, gripper: float, dt: float, max_linear: float, max_angular: float
) -> np.ndarray:
    """The 7-D steering vector moving the TCP target from ``pose_now`` to ``pose_next`` in one step.

    Args:
        pose_now: TCP target pose in the robot base frame (4×4).
        pose_next: next TCP target pose (4×4).
        gripper: gripper command in [-1, 1] (+1 open).
        dt: control period [s].
        max_linear: TCP speed of a steering value of 1 [m/s].
        max_angular: TCP angular speed of a steering value of 1 [rad/s].

    Returns:
        (7,) float32 in [-1, 1]: linear x, y, z, angular x, y, z (base frame), gripper.
    """
    lin = (pose_next[:3, 3] - pose_now[:3, 3]) / (max_linear * dt)
    rot = _rotvec(pose_next[:3, :3] @ pose_now[:3, :3].T) / (max_angular * dt)
    out = np.concatenate([lin, rot, [gripper]])
    return np.clip(out, -1.0, 1.0).astype(np.float32)


def grasped_object(model: mujoco.MjModel, data: mujoco.MjData, finger_bodies: tuple[int, int],
                   body_to_object: dict[int, int]) -> int:
    """The scene object touching both fingers, or -1."""
    touching: dict[int, set[int]] = {}
    for k in range(data.ncon):
        c = data.contact[k]
        if c.dist > 1e-3:
            continue
        b1, b2 = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
        for f, o in ((b1, b2), (b2, b1)):
            if f in finger_bodies and o in body_to_object:
                touching.setdefault(body_to_object[o], set()).add(f)
    for obj, fingers in touching.items():
        if len(fingers) == 2:
            return obj
    return -1


class FrameRecorder:
    """Accumulates per-frame records of one rollout.

    Args:
        model: compiled world.
        data: its live data (read, never written).
        arm_qpos: qpos addresses of the arm joints.
        arm_dof: dof addresses of the arm joints.
        finger_qpos: qpos addresses of the two finger joints.
        finger_bodies: body ids of the two fingers.
        tcp_site: id of the TCP site.
        object_bodies: body ids of the scene objects, in scene order.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, arm_qpos: np.ndarray, arm_dof: np.ndarray,
                 finger_qpos: np.ndarray, finger_bodies: tuple[int, int], tcp_site: int,
                 object_bodies: np.ndarray) -> None:
        self.model, self.data = model, data
        self.arm_qpos, self.arm_dof, self.finger_qpos = arm_qpos, arm_dof, finger_qpos
        self.finger_bodies = finger_bodies
        self.tcp_site = tcp_site
        self.object_bodies = np.asarray(object_bodies)
        self.body_to_object = {int(b): i for i, b in enumerate(self.object_bodies)}
        self.rows: dict[str, list[np.ndarray]] = {k: [] for k in FRAME_FIELDS}

    def __len__(self) -> int:
        return len(self.rows["time"])

    def record(self, subtask_index: int, progress: float, target_object: int, command_joint_pos: np.ndarray,
               gripper_command: float, steering: np.ndarray, safety_code: int = 0) -> int:
        """Append the current state with the command of this step; returns the grasped object."""
        d = self.data
        r = self.rows
        tcp_quat = np.empty(4)
        mujoco.mju_mat2Quat(tcp_quat, d.site_xmat[self.tcp_site])
        grasped = grasped_object(self.model, d, self.finger_bodies, self.body_to_object)
        r["time"].append(np.float64(d.time))
        r["subtask_index"].append(np.int16(subtask_index))
        r["subtask_progress"].append(np.float32(progress))
        r["target_object"].append(np.int16(target_object))
        r["joint_pos"].append(d.qpos[self.arm_qpos].copy())
        r["joint_vel"].append(d.qvel[self.arm_dof].copy())
        r["gripper_opening"].append(np.float32(d.qpos[self.finger_qpos].sum()))
        r["gripper_command"].append(np.float32(gripper_command))
        r["command_joint_pos"].append(np.asarray(command_joint_pos, dtype=np.float64).copy())
        r["tcp_pos"].append(d.site_xpos[self.tcp_site].copy())
        r["tcp_quat"].append(tcp_quat)
        r["steering"].append(np.asarray(steering, dtype=np.float32))
        r["object_pos"].append(d.xpos[self.object_bodies].copy())
        r["object_quat"].append(d.xquat[self.object_bodies].copy())
        r["grasped_object"].append(np.int16(grasped))
        r["safety_event"].append(np.int8(safety_code))
        r["qpos"].append(d.qpos.copy())
        r["qvel"].append(d.qvel.copy())
        r["act"].append(d.act.copy())
        return grasped

    def frames(self) -> dict[str, np.ndarray]:
        """The recorded frames as arrays with the dtypes of :data:`FRAME_FIELDS`."""
        out = {}
        for k, (shape, dtype) in FRAME_FIELDS.items():
            rows = self.rows[k]
            if rows:
                out[k] = np.asarray(np.stack(rows), dtype=dtype)
            else:
                dims = {"N": len(self.object_bodies), "nq": self.model.nq, "nv": self.model.nv, "na": self.model.na}
                out[k] = np.zeros((0, *(dims[s] if isinstance(s, str) else s for s in shape)), dtype=dtype)
        return out
