"""What the behaviour-cloning policy sees, as arrays: its cameras, the robot state vector (joint
positions and velocities, TCP position and orientation, finger opening, last gripper command) and,
for the privileged-state reference, the target object's pose relative to the TCP. The network
normalises the state per dimension.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from samplehd.learn.options import POLICY_CAMERAS

__all__ = ["CAMERAS"]

CAMERAS = POLICY_CAMERAS


def _rotation_columns(quat: np.ndarray) -> np.ndarray:
    """The first two columns of the rotation matrix of quaternions (..., 4: w x y z), as (..., 6).

    Unlike the quaternion, they do not change sign between q and -q, and are continuous in the pose.
    """
    q = np.asarray(quat, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y),
                     2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)], axis=-1)


def _state(joint_pos: np.ndarray, tcp_pos: np.ndarray, tcp_quat: np.ndarray, opening: np.ndarray,
           joint_vel: np.ndarray, last_gripper: np.ndarray) -> np.ndarray:
    """The policy's raw state vector(s); the network normalises it per dimension."""
    opening = np.asarray(opening, np.float64)[..., None]
    last_gripper = np.asarray(last_gripper, np.float64)[..., None]
    return np.concatenate([np.asarray(joint_pos, np.float64), np.asarray(tcp_pos, np.float64),
                           _rotation_columns(tcp_quat), opening, np.asarray(joint_vel, np.float64), last_gripper],
                          axis=-1).astype(np.float32)


def _target_features(tcp_pos: np.ndarray, object_pos: np.ndarray, object_quat: np.ndarray,
                     target: np.ndarray) -> np.ndarray:
    """Per frame: the target object's position relative to the TCP and its rotation columns (zeros
    when a frame has no target)."""
    target = np.asarray(target, int)
    rows = np.arange(len(target))
    idx = np.maximum(target, 0)
    rel = np.asarray(object_pos, np.float64)[rows, idx] - np.asarray(tcp_pos, np.float64)
    out = np.concatenate([rel, _rotation_columns(np.asarray(object_quat, np.float64)[rows, idx])], axis=1)
    out[target < 0] = 0.0
    return out.astype(np.float32)


def _joint_vel(action: str, joint_vel: Any) -> np.ndarray:
    """The joint velocities the network sees: none for waypoints (the follower moves unlike the
    demonstrations' timed paths, and the labels do not depend on the speed)."""
    v = np.asarray(joint_vel, np.float64)
    return np.zeros_like(v) if action == "waypoint" else v
