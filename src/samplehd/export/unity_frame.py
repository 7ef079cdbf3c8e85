"""SAMPLE-HD's Unity conventions: its world frame, its joint angles and its effector point.

SAMPLE-HD recorded in Unity: a left-handed world with y up, the UR5e base at
:data:`UNITY_ROBOT_BASE` [m], joint angles in degrees in the Unity rig's own zero and sign
convention, and an "effector end" 0.09 m beyond the flange along the tool axis. Its Python code
(``utils/robot.py``) maps those joint angles to standard DH angles [deg] as::

    θ1 = −j1 − 90,  θ2 = −j2 − 90,  θ3 = −j3,  θ4 = −j4 − 90,  θ5 = −j5,  θ6 = −j6

and a point ``p`` of the DH base frame to Unity as ``UNITY_ROBOT_BASE + (p_y, p_z, −p_x)``.

samplehd's base frame is parallel to its world frame (z up, right-handed, x from the robot
towards the operator, y to the operator's right). So a world point ``w`` maps to Unity as
``UNITY_ROBOT_BASE + M (w − base)`` with ``M`` = :data:`WORLD_TO_UNITY` (a reflection: det −1,
which is why Unity's frame is left-handed), and a rotation ``R`` to ``M R Mᵀ``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from samplehd.fixedmath import matmul
from samplehd.motion.order import EFFECTOR_POINT_OFFSET
from samplehd.robot.constants import TCP_OFFSET

__all__ = [
    "UNITY_EFFECTOR_OFFSET",
    "UNITY_ROBOT_BASE",
    "WORLD_TO_UNITY",
    "joints_to_unity",
    "point_to_unity",
    "quat_to_unity",
    "unity_effector_end",
    "xyz",
    "xyzw",
]

# Where SAMPLE-HD's Unity scene has the UR5e base (utils/robot.py, UR5e.position) [m].
UNITY_ROBOT_BASE = np.array([-0.422, 0.7728171, 0.2028])
# SAMPLE-HD's effector point: 0.09 m beyond the flange along the tool z axis (UR5e.effector_transform) [m];
# the planner's ``nearest`` pick order measures from the same point.
UNITY_EFFECTOR_OFFSET = EFFECTOR_POINT_OFFSET
# Rows: Unity x = base y, Unity y = base z (up), Unity z = −base x.
WORLD_TO_UNITY = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
# Unity joint j [deg] = _JOINT_SIGN * θ_DH [deg] + _JOINT_SHIFT (the inverse of utils/robot.py's map).
_JOINT_SIGN = -1.0
_JOINT_SHIFT = np.array([-90.0, -90.0, 0.0, -90.0, 0.0, 0.0])


def joints_to_unity(q: np.ndarray) -> np.ndarray:
    """Unity recorder joint angles [deg], wrapped to (−180, 180], of DH joint angles ``q`` (…, 6) [rad]."""
    j = _JOINT_SIGN * np.degrees(np.asarray(q, dtype=float)) + _JOINT_SHIFT
    return 180.0 - np.mod(180.0 - j, 360.0)


def point_to_unity(points: np.ndarray, base: np.ndarray) -> np.ndarray:
    """Unity coordinates [m] of world points (…, 3) [m]; ``base`` is the robot base in the world."""
    return UNITY_ROBOT_BASE + matmul(np.asarray(points, dtype=float) - base, WORLD_TO_UNITY.T)


def _mat_from_quat(q: np.ndarray) -> np.ndarray:
    w, x, y, z = (np.asarray(q, dtype=float) / np.linalg.norm(q, axis=-1, keepdims=True)).T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def _quat_from_mat(m: np.ndarray) -> np.ndarray:
    """(w, x, y, z) of rotation matrices (…, 3, 3), w ≥ 0."""
    xyzw_ = Rotation.from_matrix(m.reshape(-1, 3, 3)).as_quat()
    wxyz = np.concatenate([xyzw_[:, 3:], xyzw_[:, :3]], axis=1)
    wxyz *= np.where(wxyz[:, :1] < 0, -1.0, 1.0)
    return wxyz.reshape(*m.shape[:-2], 4)


def quat_to_unity(quat: np.ndarray) -> np.ndarray:
    """Unity rotation (x, y, z, w) of world orientations given as quaternions (…, 4) (w, x, y, z)."""
    q = np.asarray(quat, dtype=float)
    m = matmul(matmul(WORLD_TO_UNITY, _mat_from_quat(q.reshape(-1, 4))), WORLD_TO_UNITY.T)
    wxyz = _quat_from_mat(m).reshape(q.shape)
    return np.concatenate([wxyz[..., 1:], wxyz[..., :1]], axis=-1)


def unity_effector_end(tcp_pos: np.ndarray, tcp_quat: np.ndarray, base: np.ndarray) -> np.ndarray:
    """SAMPLE-HD's effector point in Unity coordinates [m] from samplehd's TCP pose in the world.

    The TCP lies :data:`~samplehd.robot.constants.TCP_OFFSET` beyond the flange on the tool z axis;
    SAMPLE-HD's point lies :data:`UNITY_EFFECTOR_OFFSET` beyond it.
    """
    z_axis = _mat_from_quat(np.asarray(tcp_quat, dtype=float).reshape(-1, 4))[:, :, 2].reshape(np.shape(tcp_pos))
    world = np.asarray(tcp_pos, dtype=float) + (UNITY_EFFECTOR_OFFSET - TCP_OFFSET) * z_axis
    return point_to_unity(world, base)


def xyz(v: np.ndarray, digits: int = 7) -> dict[str, float]:
    """``{x, y, z}`` as SAMPLE-HD's JSON writes vectors (keys in this order)."""
    return {"x": round(float(v[0]), digits), "y": round(float(v[1]), digits), "z": round(float(v[2]), digits)}


def xyzw(q: np.ndarray, digits: int = 7) -> dict[str, float]:
    """``{x, y, z, w}`` of a Unity quaternion given as (x, y, z, w)."""
    return {k: round(float(v), digits) for k, v in zip("xyzw", q, strict=True)}
