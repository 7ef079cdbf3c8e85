"""The one set of rotation and pose helpers every stage uses: quaternions (w, x, y, z), rotation
matrices, yaws about the vertical and rotation vectors.

The robot floor below keeps its own scalar forms (robot.kinematics, robot.controller), written for
its hot loops; everything above it uses these."""

from __future__ import annotations

import math

import numpy as np

from samplehd.fixedmath import arccos, half_turn_axis, norm

__all__ = [
    "look_at_quat",
    "mat_to_quat",
    "quat_from_yaw",
    "quat_to_mat",
    "rotvec",
    "rotvecs",
    "yaw_from_quat",
    "yaw_rotation_2d",
]


def look_at_quat(
    eye: np.ndarray | tuple[float, float, float],
    target: np.ndarray | tuple[float, float, float],
    up: tuple[float, float, float] = (0.0, 0.0, 1.0),
) -> np.ndarray:
    """Quaternion (w, x, y, z) of a MuJoCo camera at `eye` looking at `target`.

    MuJoCo cameras look along their -z axis with +y up in the image.
    """
    eye_a, target_a, up_a = (np.asarray(v, dtype=float) for v in (eye, target, up))
    z = eye_a - target_a
    z /= norm(z)
    x = np.cross(up_a, z)
    if norm(x) < 1e-9:
        x = np.cross((0.0, 1.0, 0.0), z)
    x /= norm(x)
    y = np.cross(z, x)
    rot = np.stack([x, y, z], axis=1)
    return mat_to_quat(rot)


def mat_to_quat(rot: np.ndarray) -> np.ndarray:
    """Quaternion (w, x, y, z) of a 3×3 rotation matrix, with w ≥ 0."""
    m = np.asarray(rot, dtype=float)
    t = np.trace(m)
    if t > 0:
        s = np.sqrt(t + 1.0) * 2
        q = np.array([0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s])
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k]) * 2
        q = np.empty(4)
        q[0] = (m[k, j] - m[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (m[j, i] + m[i, j]) / s
        q[1 + k] = (m[k, i] + m[i, k]) / s
    q /= norm(q)
    return q if q[0] >= 0 else -q


def quat_to_mat(quat: np.ndarray) -> np.ndarray:
    """3×3 rotation matrix of a quaternion (w, x, y, z)."""
    w, x, y, z = np.asarray(quat, dtype=float) / norm(quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def quat_from_yaw(yaw: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of a rotation by `yaw` [rad] about world z."""
    return np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])


def yaw_from_quat(quat: np.ndarray) -> float:
    """Yaw [rad] of a quaternion (w, x, y, z): the heading of its rotated x axis in the x-y plane."""
    r = quat_to_mat(quat)
    return math.atan2(float(r[1, 0]), float(r[0, 0]))


def yaw_rotation_2d(yaw: np.ndarray) -> np.ndarray:
    """Rotations (..., 2, 2) about the vertical by yaw [rad]."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def rotvec(r: np.ndarray) -> np.ndarray:
    """Rotation vector of a rotation matrix [rad]."""
    cos = float(np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0))
    ang = math.acos(cos)
    if ang < 1e-9:
        return np.zeros(3)
    v = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    s = float(norm(v))
    if s < 1e-9:
        return half_turn_axis(r) * ang
    return v / s * ang


def rotvecs(r: np.ndarray) -> np.ndarray:
    """Rotation vectors of (N, 3, 3) rotation matrices [rad], as :func:`rotvec` row by row."""
    ang = arccos(np.clip((np.trace(r, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0))
    v = np.stack([r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]], axis=1)
    s = np.linalg.norm(v, axis=1)
    out = np.zeros_like(v)
    regular = (ang >= 1e-9) & (s >= 1e-9)
    out[regular] = v[regular] / s[regular, None] * ang[regular, None]
    for k in np.flatnonzero((ang >= 1e-9) & (s < 1e-9)):  # half turns
        out[k] = rotvec(r[k])
    return out
