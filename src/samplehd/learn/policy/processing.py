"""What the behaviour-cloning policy sees, as arrays: its cameras, the robot state vector (joint
positions and velocities, TCP position and orientation, finger opening, last gripper command) and,
for the privileged-state reference, the target object's pose relative to the TCP. The network
normalises the state per dimension.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from samplehd.learn.actions import rotation_columns
from samplehd.learn.policy.configuration import CAMERAS

__all__ = ["CAMERAS", "policy_state", "seen_joint_velocities", "target_features"]



def policy_state(joint_pos: np.ndarray, tcp_pos: np.ndarray, tcp_quat: np.ndarray, opening: np.ndarray,
           joint_vel: np.ndarray, last_gripper: np.ndarray) -> np.ndarray:
    """The policy's raw state vector(s); the network normalises it per dimension."""
    opening = np.asarray(opening, np.float64)[..., None]
    last_gripper = np.asarray(last_gripper, np.float64)[..., None]
    return np.concatenate([np.asarray(joint_pos, np.float64), np.asarray(tcp_pos, np.float64),
                           rotation_columns(tcp_quat), opening, np.asarray(joint_vel, np.float64), last_gripper],
                          axis=-1).astype(np.float32)


def target_features(tcp_pos: np.ndarray, object_pos: np.ndarray, object_quat: np.ndarray,
                     target: np.ndarray) -> np.ndarray:
    """Per frame: the target object's position relative to the TCP and its rotation columns (zeros
    when a frame has no target)."""
    target = np.asarray(target, int)
    rows = np.arange(len(target))
    idx = np.maximum(target, 0)
    rel = np.asarray(object_pos, np.float64)[rows, idx] - np.asarray(tcp_pos, np.float64)
    out = np.concatenate([rel, rotation_columns(np.asarray(object_quat, np.float64)[rows, idx])], axis=1)
    out[target < 0] = 0.0
    return out.astype(np.float32)


def seen_joint_velocities(action: str, joint_vel: Any) -> np.ndarray:
    """The joint velocities the network sees: none for waypoints (the follower moves unlike the
    demonstrations' timed paths, and the labels do not depend on the speed)."""
    v = np.asarray(joint_vel, np.float64)
    return np.zeros_like(v) if action == "waypoint" else v
