"""The SAMPLE-HD steering vector of a motion between TCP targets: linear and angular TCP velocity
scaled by the controller's steering speeds, and the gripper command.

The planner attaches it to every control target it yields (the dataset stores it per frame), and the
oracle turns targets into steering actions with it; the robot controller's ``steering`` mode
inverts it.
"""

from __future__ import annotations

import numpy as np

from samplehd.fixedmath import matmul
from samplehd.world.transforms import rotvec, rotvecs

__all__ = ["steering_from_targets", "steering_motion"]


def steering_motion(poses_now: np.ndarray, poses_next: np.ndarray, dt: float, max_linear: float,
                    max_angular: float) -> np.ndarray:
    """The first six steering values (unclipped) of N steps between TCP target poses (N, 4, 4); see
    :func:`steering_from_targets`."""
    lin = (poses_next[:, :3, 3] - poses_now[:, :3, 3]) / (max_linear * dt)
    rot = rotvecs(matmul(poses_next[:, :3, :3], np.swapaxes(poses_now[:, :3, :3], 1, 2))) / (max_angular * dt)
    return np.concatenate([lin, rot], axis=1)


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
    rot = rotvec(matmul(pose_next[:3, :3], pose_now[:3, :3].T)) / (max_angular * dt)
    out = np.concatenate([lin, rot, [gripper]])
    return np.clip(out, -1.0, 1.0).astype(np.float32)
