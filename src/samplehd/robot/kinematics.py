"""Analytic forward and inverse kinematics of the UR5e.

All poses are 4×4 homogeneous transforms in the robot base frame (DH frame 0) [m]. The flange frame
is DH frame 6; the tool centre point (TCP) is the flange frame shifted by ``tool_offset`` along its
z axis (the approach direction), :data:`~samplehd.robot.constants.TCP_OFFSET` for the gripper.

Inverse kinematics is the standard closed-form solution of the UR family (shoulder, elbow and wrist
each take one of two branches, so up to 8 solutions). Solutions are shifted by multiples of 2π to
the representation nearest a seed inside the joint limits, and the nearest solution is returned.

Example:
    >>> import numpy as np
    >>> from samplehd.robot.constants import HOME_QPOS
    >>> from samplehd.robot.kinematics import fk_tcp, ik_tcp
    >>> pose = fk_tcp(HOME_QPOS)
    >>> q = ik_tcp(pose, seed=HOME_QPOS)
    >>> bool(np.allclose(q, HOME_QPOS, atol=1e-9))
    True
"""

from __future__ import annotations

import math

import numpy as np

from samplehd.errors import KinematicsError, UnreachableError
from samplehd.fixedmath import arccos, arcsin, arctan2, inv_rigid, matmul, norm
from samplehd.robot.constants import DH_A, DH_ALPHA, DH_D, JOINT_LIMITS, NUM_JOINTS, TCP_OFFSET

__all__ = [
    "fk_flange",
    "fk_tcp",
    "forward_kinematics",
    "ik_all",
    "ik_batch",
    "ik_flange",
    "ik_nearest_rows",
    "ik_path",
    "ik_tcp",
    "inverse_kinematics",
    "pose_from_pos_quat",
    "pos_quat_from_pose",
    "wrap_to_limits",
]

_D1, _D4, _D5, _D6 = (float(DH_D[i]) for i in (0, 3, 4, 5))
_A2, _A3 = float(DH_A[1]), float(DH_A[2])
_TWO_PI = 2.0 * np.pi
_LIMIT_ROWS: list[list[float]] = JOINT_LIMITS.tolist()
# Below this |sin(q5)| the wrist is singular (axes 4 and 6 parallel); q2+q3+q4 then comes from the seed.
_WRIST_SINGULAR = 1e-7
# Tolerance on cosines slightly outside [-1, 1] caused by rounding at the workspace boundary.
_COS_TOL = 1e-9


def _check_q(q: np.ndarray | list[float] | tuple[float, ...]) -> np.ndarray:
    arr = np.asarray(q, dtype=float)
    if arr.shape[-1:] != (NUM_JOINTS,):
        raise KinematicsError(f"joint vector must have shape (..., 6), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise KinematicsError("joint vector contains NaN or infinite values")
    return arr


def _check_pose(pose: np.ndarray) -> np.ndarray:
    arr = np.asarray(pose, dtype=float)
    if arr.shape[-2:] != (4, 4):
        raise KinematicsError(f"pose must be a 4x4 homogeneous transform, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise KinematicsError("pose contains NaN or infinite values")
    rot = arr[..., :3, :3]
    err = np.abs(matmul(rot, np.swapaxes(rot, -1, -2)) - np.eye(3)).max() if arr.size else 0.0
    if err > 1e-6:
        raise KinematicsError(f"pose rotation is not orthonormal (max error {err:.2e})")
    return arr


def _check_pose_rows(rows: list[list[float]]) -> None:
    """Validate one pose given as nested lists (cheaper than numpy for a single 4x4)."""
    for row in rows:
        if not all(map(math.isfinite, row)):
            raise KinematicsError("pose contains NaN or infinite values")
    r0, r1, r2 = rows[0], rows[1], rows[2]
    for i in range(3):
        for j in range(i, 3):
            dot = r0[i] * r0[j] + r1[i] * r1[j] + r2[i] * r2[j]
            if abs(dot - (1.0 if i == j else 0.0)) > 1e-6:
                raise KinematicsError(f"pose rotation is not orthonormal (column dot error {dot:.2e})")


def _tool(offset: float) -> np.ndarray:
    t = np.eye(4)
    t[2, 3] = offset
    return t


def forward_kinematics(q: np.ndarray, tool_offset: float = 0.0) -> np.ndarray:
    """Pose of the flange (or a tool point on its z axis) in the base frame.

    Args:
        q: joint angles, shape (6,) or (..., 6) [rad].
        tool_offset: distance of the tool point from the flange along the flange z axis [m].

    Returns:
        Homogeneous transforms, shape (4, 4) or (..., 4, 4).

    Raises:
        KinematicsError: wrong shape or non-finite values.
    """
    q = _check_q(q)
    ct, st = np.cos(q), np.sin(q)
    ca, sa = np.cos(DH_ALPHA), np.sin(DH_ALPHA)
    # Per-joint DH transforms Rz(q) Tz(d) Tx(a) Rx(alpha), built for all joints at once.
    t = np.zeros(q.shape + (4, 4))
    t[..., 0, 0] = ct
    t[..., 0, 1] = -st * ca
    t[..., 0, 2] = st * sa
    t[..., 0, 3] = DH_A * ct
    t[..., 1, 0] = st
    t[..., 1, 1] = ct * ca
    t[..., 1, 2] = -ct * sa
    t[..., 1, 3] = DH_A * st
    t[..., 2, 1] = sa
    t[..., 2, 2] = ca
    t[..., 2, 3] = DH_D
    t[..., 3, 3] = 1.0
    out = t[..., 0, :, :]
    for i in range(1, NUM_JOINTS):
        out = matmul(out, t[..., i, :, :])
    if tool_offset:
        out = out.copy()
        out[..., :3, 3] += tool_offset * out[..., :3, 2]
    return out


def fk_flange(q: np.ndarray) -> np.ndarray:
    """Flange pose (DH frame 6) in the base frame for joint angles ``q`` [rad]."""
    return forward_kinematics(q, 0.0)


def fk_tcp(q: np.ndarray) -> np.ndarray:
    """Gripper TCP pose in the base frame for joint angles ``q`` [rad]."""
    return forward_kinematics(q, TCP_OFFSET)


def _ik_core(pose: np.ndarray, seed234: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All 8 closed-form branches for flange poses ``pose`` (N, 4, 4).

    At the wrist singularity (sin q5 = 0, joints 2, 3, 4 and 6 parallel) the arm is redundant;
    q2 + q3 + q4 is then taken from the seed (``seed234``, shape (N,)) and q6 follows. (The
    single-pose path, :func:`inverse_kinematics`, also moves q234 into the elbow's reach.)

    Returns:
        (q, valid): q of shape (N, 8, 6) in (-π, π], valid of shape (N, 8).
    """
    n = pose.shape[0]
    r = pose[:, :3, :3]
    p = pose[:, :3, 3]
    # Wrist centre (origin of frame 5) lies d6 behind the flange along its z axis.
    p5 = p - _D6 * r[:, :, 2]
    rxy = np.hypot(p5[:, 0], p5[:, 1])
    ok1 = rxy >= _D4 * (1.0 - 1e-12)
    phi = arccos(np.clip(_D4 / np.maximum(rxy, 1e-300), -1.0, 1.0))
    psi = arctan2(p5[:, 1], p5[:, 0])
    # Branch index layout: [shoulder (2), wrist (2), elbow (2)] -> 8.
    q1 = np.stack([psi + phi, psi - phi], axis=1) + np.pi / 2  # (N, 2)
    s1, c1 = np.sin(q1), np.cos(q1)
    c5 = (p[:, None, 0] * s1 - p[:, None, 1] * c1 - _D4) / _D6
    ok5 = np.abs(c5) <= 1.0 + _COS_TOL
    a5 = arccos(np.clip(c5, -1.0, 1.0))
    q5 = np.stack([a5, -a5], axis=2)  # (N, 2, 2)
    s5 = np.sin(q5)
    nx, ny = r[:, None, None, 0, 0], r[:, None, None, 1, 0]
    ox, oy = r[:, None, None, 0, 1], r[:, None, None, 1, 1]
    s1e, c1e = s1[:, :, None], c1[:, :, None]
    singular = np.abs(s5) < _WRIST_SINGULAR
    s5safe = np.where(singular, 1.0, s5)
    q6 = arctan2((-ox * s1e + oy * c1e) / s5safe, (nx * s1e - ny * c1e) / s5safe)
    # Singular wrist: keep the seed's q234 and solve q6 from Rz(-q234) R16 = Ry(-q5) Rz(q6).
    s234, c234 = np.sin(seed234)[:, None, None], np.cos(seed234)[:, None, None]
    r00, r01 = c1e * nx + s1e * ny, c1e * ox + s1e * oy
    r10, r11 = r[:, None, None, 2, 0], r[:, None, None, 2, 1]
    q6_singular = arctan2(-s234 * r00 + c234 * r10, -s234 * r01 + c234 * r11)
    q6 = np.where(singular, q6_singular, q6)
    # Frame 1 -> frame 4 transform: T14 = inv(T01) T06 inv(T45 T56).
    q1b = np.broadcast_to(q1[:, :, None], (n, 2, 2))
    t01 = _dh_single(q1b, 0)
    t45 = _dh_single(q5, 4)
    t56 = _dh_single(q6, 5)
    t14 = matmul(matmul(inv_rigid(t01), pose[:, None, None]), inv_rigid(matmul(t45, t56)))
    p13 = t14[..., :3, 3] - _D4 * t14[..., :3, 1]
    len2 = p13[..., 0] ** 2 + p13[..., 1] ** 2
    c3 = (len2 - _A2 * _A2 - _A3 * _A3) / (2.0 * _A2 * _A3)
    ok3 = np.abs(c3) <= 1.0 + _COS_TOL
    a3 = arccos(np.clip(c3, -1.0, 1.0))
    q3 = np.stack([a3, -a3], axis=3)  # (N, 2, 2, 2)
    length = np.sqrt(len2)[..., None]
    q2 = -arctan2(p13[..., 1], -p13[..., 0])[..., None] + arcsin(
        np.clip(_A3 * np.sin(q3) / np.maximum(length, 1e-300), -1.0, 1.0)
    )
    t12 = _dh_single(q2, 1)
    t23 = _dh_single(q3, 2)
    t34 = matmul(inv_rigid(matmul(t12, t23)), t14[..., None, :, :])
    q4 = arctan2(t34[..., 1, 0], t34[..., 0, 0])
    shape = (n, 2, 2, 2)
    q = np.stack(
        [
            np.broadcast_to(q1[:, :, None, None], shape),
            q2,
            q3,
            q4,
            np.broadcast_to(q5[..., None], shape),
            np.broadcast_to(q6[..., None], shape),
        ],
        axis=-1,
    ).reshape(n, 8, NUM_JOINTS)
    valid = (ok1[:, None, None, None] & ok5[:, :, None, None] & np.broadcast_to(ok3[..., None], shape)).reshape(n, 8)
    q = np.mod(q + np.pi, _TWO_PI) - np.pi
    return q, valid & np.all(np.isfinite(q), axis=-1)


def _singular_q234(cx: float, cy: float, seed234: float) -> float:
    """q2+q3+q4 nearest ``seed234`` that lets the elbow reach the wrist at a singular wrist.

    With sin q5 = 0 the frame-3 origin is o3 = c + d5 (-sin q234, cos q234), a circle of radius d5
    about c (the wrist point below the d5 offset); the elbow reaches |o3| in [|a2|-|a3|, |a2|+|a3|].
    Writing q234 = phi + gamma - π/2 with gamma = atan2(c), |o3|² = |c|² + d5² + 2 d5 |c| cos(phi);
    clip the seed's phi into the reachable band of cos(phi).
    """
    rc = math.hypot(cx, cy)
    if rc < 1e-12:
        return seed234
    gamma = math.atan2(cy, cx)
    span = 2.0 * _D5 * rc
    lo = ((abs(_A2) - abs(_A3)) ** 2 - rc * rc - _D5 * _D5) / span
    hi = ((abs(_A2) + abs(_A3)) ** 2 - rc * rc - _D5 * _D5) / span
    if lo > 1.0 or hi < -1.0:
        return seed234
    phi_min, phi_max = math.acos(min(1.0, hi)), math.acos(max(-1.0, lo))
    phi = math.remainder(seed234 - gamma + math.pi / 2, _TWO_PI)
    phi = math.copysign(min(max(abs(phi), phi_min), phi_max), phi)
    return phi + gamma - math.pi / 2


def _ik_scalar(rows: list[list[float]], seed234: float) -> list[list[float]]:
    """All closed-form solutions of one flange pose with scalar math (fast for a single pose).

    Derivation: with R16 = Rx(-π/2) Rz(-q1) R06 the flange rotation seen from frame 1,
    R16 = Rz(q2+q3+q4) Ry(-q5) Rz(q6), and the wrist centre minus the d4/d5 offsets is reached by
    the planar two-link arm (a2, a3).
    """
    (nx, ox, ax, px), (ny, oy, ay, py), (nz, oz, az, pz) = rows[0], rows[1], rows[2]
    p5x, p5y = px - _D6 * ax, py - _D6 * ay
    rxy = math.hypot(p5x, p5y)
    if rxy < _D4 * (1.0 - 1e-12):
        return []
    phi = math.acos(min(1.0, _D4 / rxy))
    psi = math.atan2(p5y, p5x)
    out: list[list[float]] = []
    for q1 in (psi + phi + math.pi / 2, psi - phi + math.pi / 2):
        s1, c1 = math.sin(q1), math.cos(q1)
        c5 = s1 * ax - c1 * ay
        if abs(c5) > 1.0 + _COS_TOL:
            continue
        a5 = math.acos(max(-1.0, min(1.0, c5)))
        # Rows of R16 and p16 needed below.
        r00, r01, r02 = c1 * nx + s1 * ny, c1 * ox + s1 * oy, c1 * ax + s1 * ay
        r10, r11, r12 = nz, oz, az
        r20, r21 = s1 * nx - c1 * ny, s1 * ox - c1 * oy
        x16, y16 = c1 * px + s1 * py, pz - _D1
        for q5 in (a5, -a5):
            s5 = math.sin(q5)
            if abs(s5) < _WRIST_SINGULAR:
                # Singular wrist (redundant arm): q234 nearest the seed's that the elbow can
                # reach, then q6 from Rz(-q234) R16 = Ry(-q5) Rz(q6).
                q234 = _singular_q234(x16 - _D6 * r02, y16 - _D6 * r12, seed234)
                s234, c234 = math.sin(q234), math.cos(q234)
                q6 = math.atan2(-s234 * r00 + c234 * r10, -s234 * r01 + c234 * r11)
            else:
                q6 = math.atan2(-r21 / s5, r20 / s5)
                c6, s6 = math.cos(q6), math.sin(q6)
                cq5 = math.cos(q5)
                # Rz(q234) = R16 (Ry(-q5) Rz(q6))^T; its first column.
                m00 = r00 * cq5 * c6 - r01 * cq5 * s6 - r02 * s5
                m10 = r10 * cq5 * c6 - r11 * cq5 * s6 - r12 * s5
                q234 = math.atan2(m10, m00)
                s234, c234 = math.sin(q234), math.cos(q234)
            # Wrist-centre chain: o3 = p16 - d6 z16 - d5 (s234, -c234) (planar part).
            x3 = x16 - _D6 * r02 - _D5 * s234
            y3 = y16 - _D6 * r12 + _D5 * c234
            c3 = (x3 * x3 + y3 * y3 - _A2 * _A2 - _A3 * _A3) / (2.0 * _A2 * _A3)
            if abs(c3) > 1.0 + _COS_TOL:
                continue
            a3 = math.acos(max(-1.0, min(1.0, c3)))
            for q3 in (a3, -a3):
                q2 = math.atan2(y3, x3) - math.atan2(_A3 * math.sin(q3), _A2 + _A3 * math.cos(q3))
                out.append([q1, q2, q3, q234 - q2 - q3, q5, q6])
    return out


def _nearest_scalar(solutions: list[list[float]], seed: list[float], limits: list[list[float]]) -> list[float] | None:
    """The solution nearest ``seed`` after shifting each angle by 2π into ``limits``, or None."""
    best: list[float] | None = None
    best_d = math.inf
    two_pi = _TWO_PI
    remainder = math.remainder
    for sol in solutions:
        cand: list[float] = []
        d = 0.0
        for qi, si, (lo, hi) in zip(sol, seed, limits):  # noqa: B905 - lengths are fixed (6)
            # Representation nearest the seed, then into the limits if it is just outside.
            v = si + remainder(qi - si, two_pi)
            if v > hi:
                v -= two_pi
                if v < lo:
                    break
            elif v < lo:
                v += two_pi
                if v > hi:
                    break
            d += (v - si) * (v - si)
            if d >= best_d:
                break
            cand.append(v)
        else:
            best, best_d = cand, d
    return best


def _dh_single(theta: np.ndarray, i: int) -> np.ndarray:
    """DH transform of joint ``i`` for angles of any shape, shape theta.shape + (4, 4)."""
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = math.cos(DH_ALPHA[i]), math.sin(DH_ALPHA[i])
    t = np.zeros(theta.shape + (4, 4))
    t[..., 0, 0] = ct
    t[..., 0, 1] = -st * ca
    t[..., 0, 2] = st * sa
    t[..., 0, 3] = DH_A[i] * ct
    t[..., 1, 0] = st
    t[..., 1, 1] = ct * ca
    t[..., 1, 2] = -ct * sa
    t[..., 1, 3] = DH_A[i] * st
    t[..., 2, 1] = sa
    t[..., 2, 2] = ca
    t[..., 2, 3] = DH_D[i]
    t[..., 3, 3] = 1.0
    return t


def wrap_to_limits(q: np.ndarray, seed: np.ndarray, limits: np.ndarray = JOINT_LIMITS) -> tuple[np.ndarray, np.ndarray]:
    """Shift each angle by multiples of 2π to the value nearest ``seed`` inside ``limits``.

    Args:
        q: joint angles, shape (..., 6) [rad].
        seed: reference configuration, broadcastable to ``q`` [rad].
        limits: (6, 2) lower and upper joint limits [rad].

    Returns:
        (wrapped, ok): wrapped angles and whether every joint has a representation inside its limits.
    """
    lo, hi = limits[:, 0], limits[:, 1]
    k_best = np.round((seed - q) / _TWO_PI)
    k_min = np.ceil((lo - q) / _TWO_PI - 1e-12)
    k_max = np.floor((hi - q) / _TWO_PI + 1e-12)
    k = np.clip(k_best, k_min, k_max)
    ok = np.all(k_min <= k_max, axis=-1)
    return q + _TWO_PI * k, ok


def ik_all(pose: np.ndarray, tool_offset: float = 0.0) -> np.ndarray:
    """Every closed-form IK solution of one pose, each angle in (-π, π].

    Args:
        pose: (4, 4) pose of the tool point in the base frame [m].
        tool_offset: distance of the tool point from the flange along its z axis [m].

    Returns:
        Solutions of shape (k, 6) [rad], 0 ≤ k ≤ 8 (k = 0 when the pose is out of reach).

    Raises:
        KinematicsError: wrong shape, non-finite values or non-orthonormal rotation.
    """
    pose = _check_pose(pose)
    if pose.shape != (4, 4):
        raise KinematicsError(f"pose must have shape (4, 4), got {pose.shape}")
    flange = matmul(pose, _tool(-tool_offset)) if tool_offset else pose
    q, valid = _ik_core(flange[None], np.zeros(1))
    return q[0][valid[0]]


def ik_batch(
    poses: np.ndarray,
    seeds: np.ndarray,
    tool_offset: float = 0.0,
    limits: np.ndarray = JOINT_LIMITS,
) -> tuple[np.ndarray, np.ndarray]:
    """Vectorised IK: for each pose the solution nearest its seed inside the joint limits.

    Args:
        poses: (N, 4, 4) poses of the tool point in the base frame [m].
        seeds: (N, 6) or (6,) seed configurations [rad].
        tool_offset: distance of the tool point from the flange along its z axis [m].
        limits: (6, 2) joint limits [rad].

    Returns:
        (q, ok): q of shape (N, 6) [rad] (the seed where ``ok`` is False) and ok of shape (N,).

    Raises:
        KinematicsError: wrong shapes or non-finite values.
    """
    poses = _check_pose(poses)
    if poses.ndim != 3:
        raise KinematicsError(f"poses must have shape (N, 4, 4), got {poses.shape}")
    n = poses.shape[0]
    seeds = np.broadcast_to(_check_q(seeds), (n, NUM_JOINTS))
    flange = matmul(poses, _tool(-tool_offset)) if tool_offset else poses
    q, valid = _ik_core(flange, seeds[:, 1] + seeds[:, 2] + seeds[:, 3])
    q, in_limits = wrap_to_limits(q, seeds[:, None, :], limits)
    valid &= in_limits
    dist = np.where(valid, np.sum((q - seeds[:, None, :]) ** 2, axis=-1), np.inf)
    best = np.argmin(dist, axis=1)
    ok = np.isfinite(dist[np.arange(n), best])
    out = np.where(ok[:, None], q[np.arange(n), best], seeds)
    return out, ok


def ik_path(
    poses: np.ndarray,
    q_start: np.ndarray,
    tool_offset: float = 0.0,
    limits: np.ndarray = JOINT_LIMITS,
) -> tuple[np.ndarray, int]:
    """IK along a sequence of poses, each solution nearest the previous one (the first: ``q_start``).

    All branches of all poses are solved in one vectorised pass; only the choice of branch runs
    pose by pose. At a wrist singularity q2 + q3 + q4 is taken from ``q_start``.

    Args:
        poses: (N, 4, 4) poses of the tool point in the base frame [m].
        q_start: (6,) configuration before the first pose [rad].
        tool_offset: distance of the tool point from the flange along its z axis [m].
        limits: (6, 2) joint limits [rad].

    Returns:
        (q, failed): q of shape (N, 6) [rad]; ``failed`` is the index of the first pose with no
        solution inside the limits (rows from there on are undefined), or -1.

    Raises:
        KinematicsError: wrong shapes or non-finite values.
    """
    poses = _check_pose(poses)
    if poses.ndim != 3:
        raise KinematicsError(f"poses must have shape (N, 4, 4), got {poses.shape}")
    q = _check_q(q_start).astype(float)
    n = poses.shape[0]
    flange = matmul(poses, _tool(-tool_offset)) if tool_offset else poses
    branches, valid = _ik_core(flange, np.full(n, q[1] + q[2] + q[3]))
    out = np.empty((n, NUM_JOINTS))
    lo, hi = limits[:, 0], limits[:, 1]
    k_min = np.ceil((lo - branches) / _TWO_PI - 1e-12)
    k_max = np.floor((hi - branches) / _TWO_PI + 1e-12)
    valid = valid & np.all(k_min <= k_max, axis=-1)
    for i in range(n):
        k = np.clip(np.round((q - branches[i]) / _TWO_PI), k_min[i], k_max[i])
        cand = branches[i] + _TWO_PI * k
        dist = np.where(valid[i], np.sum((cand - q) ** 2, axis=-1), np.inf)
        best = int(np.argmin(dist))
        if not np.isfinite(dist[best]):
            return out, i
        q = cand[best]
        out[i] = q
    return out, -1


def inverse_kinematics(
    pose: np.ndarray,
    seed: np.ndarray,
    tool_offset: float = 0.0,
    limits: np.ndarray = JOINT_LIMITS,
) -> np.ndarray:
    """The IK solution nearest ``seed`` inside the joint limits.

    Args:
        pose: (4, 4) pose of the tool point in the base frame [m].
        seed: (6,) reference configuration [rad].
        tool_offset: distance of the tool point from the flange along its z axis [m].
        limits: (6, 2) joint limits [rad].

    Returns:
        Joint angles, shape (6,) [rad].

    Raises:
        UnreachableError: no solution inside the limits reaches the pose.
        KinematicsError: wrong shapes or non-finite values.
    """
    pose = np.asarray(pose, dtype=float)
    if pose.shape != (4, 4):
        raise KinematicsError(f"pose must have shape (4, 4), got {pose.shape}")
    seed = np.asarray(seed, dtype=float)
    if seed.shape != (NUM_JOINTS,):
        raise KinematicsError(f"seed must have shape (6,), got {seed.shape}")
    seed_list = seed.tolist()
    if not all(map(math.isfinite, seed_list)):
        raise KinematicsError("seed contains NaN or infinite values")
    rows = pose.tolist()
    _check_pose_rows(rows)
    limit_rows = _LIMIT_ROWS if limits is JOINT_LIMITS else np.asarray(limits, dtype=float).tolist()
    best = ik_nearest_rows(rows, seed_list, tool_offset, limit_rows)
    if best is None:
        pos = pose[:3, 3]
        raise UnreachableError(
            f"pose at ({pos[0]:.3f}, {pos[1]:.3f}, {pos[2]:.3f}) m in the base frame is out of reach "
            "of the UR5e within its joint limits"
        )
    return np.array(best)


def ik_nearest_rows(
    rows: list[list[float]], seed: list[float], tool_offset: float = 0.0, limits: list[list[float]] | None = None
) -> list[float] | None:
    """Unchecked fast path of :func:`inverse_kinematics` on plain lists (for per-step control).

    Args:
        rows: the first three rows of a valid pose (orthonormal rotation, finite) [m]; not modified.
        seed: 6 finite joint angles [rad].
        tool_offset: distance of the tool point from the flange along its z axis [m].
        limits: 6 (lower, upper) pairs [rad]; default the UR5e limits.

    Returns:
        The solution nearest ``seed`` inside the limits, or None if there is none.
    """
    if tool_offset:
        # Flange origin = tool point minus tool_offset along the approach (z) axis.
        rows = [[r[0], r[1], r[2], r[3] - tool_offset * r[2]] for r in rows[:3]]
    seed234 = seed[1] + seed[2] + seed[3]
    return _nearest_scalar(_ik_scalar(rows, seed234), seed, _LIMIT_ROWS if limits is None else limits)


def ik_flange(pose: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """IK of the flange pose nearest ``seed`` [rad]; see :func:`inverse_kinematics`."""
    return inverse_kinematics(pose, seed, 0.0)


def ik_tcp(pose: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """IK of the gripper TCP pose nearest ``seed`` [rad]; see :func:`inverse_kinematics`."""
    return inverse_kinematics(pose, seed, TCP_OFFSET)


def pose_from_pos_quat(pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """4×4 transform from a position [m] and a unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in np.asarray(quat, dtype=float) / norm(quat))
    t = np.eye(4)
    t[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    t[:3, 3] = pos
    return t


def pos_quat_from_pose(pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position [m] and unit quaternion (w, x, y, z, w ≥ 0) of a 4×4 transform."""
    import mujoco  # samplehd is imported first by every entry point (GL backend choice)

    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(pose[:3, :3]).reshape(9))
    if quat[0] < 0:
        quat = -quat
    return pose[:3, 3].copy(), quat
