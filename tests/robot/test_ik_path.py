"""ik_path: batched IK along a pose sequence equals the pose-by-pose loop of ik_batch, each solution
seeded with the previous one; FK of the result reproduces the poses; an unreachable pose reports its
index."""

from __future__ import annotations

import numpy as np
import pytest

from samplehd.errors import KinematicsError
from samplehd.motion.trajectory import interpolate_pose
from samplehd.robot.constants import HOME_QPOS, JOINT_LIMITS, TCP_OFFSET
from samplehd.robot.kinematics import fk_tcp, forward_kinematics, ik_batch, ik_path

_FAR = (2.0, 0.0, 0.3)  # base frame [m]: beyond the UR5e's reach


def _sequential(
    poses: np.ndarray, q_start: np.ndarray, tool_offset: float, limits: np.ndarray = JOINT_LIMITS
) -> tuple[np.ndarray, int]:
    """The reference: one ik_batch call per pose, seeded with the previous solution."""
    q = np.asarray(q_start, dtype=float)
    out = np.empty((len(poses), 6))
    for k in range(len(poses)):
        sol, ok = ik_batch(poses[k : k + 1], q[None], tool_offset, limits)
        if not ok[0]:
            return out[:k], k
        q = sol[0]
        out[k] = q
    return out, -1


def _smooth_joint_path(seed: int, n: int = 80) -> np.ndarray:
    """A smooth joint path around home (away from the wrist and elbow singularities)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n)[:, None]
    amp = rng.uniform(-0.35, 0.35, 6)
    freq = rng.uniform(0.5, 1.5, 6)
    return HOME_QPOS + amp * np.sin(np.pi * freq * t)


def _line(start: np.ndarray, end: np.ndarray, n: int = 60) -> np.ndarray:
    return np.array([interpolate_pose(start, end, s) for s in np.linspace(0.0, 1.0, n)])


def _shifted(pose: np.ndarray, dxyz: tuple[float, float, float], yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    out = pose.copy()
    out[:3, :3] = rz @ pose[:3, :3]
    out[:3, 3] += dxyz
    return out


def _assert_fk_reproduces(q: np.ndarray, poses: np.ndarray, tool_offset: float) -> None:
    np.testing.assert_allclose(forward_kinematics(q, tool_offset)[:, :3, 3], poses[:, :3, 3], atol=1e-6)
    np.testing.assert_allclose(forward_kinematics(q, tool_offset)[:, :3, :3], poses[:, :3, :3], atol=1e-6)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("tool_offset", [0.0, TCP_OFFSET])
def test_smooth_joint_path_matches_the_sequential_loop(seed: int, tool_offset: float) -> None:
    qs = _smooth_joint_path(seed)
    poses = forward_kinematics(qs, tool_offset)
    q, failed = ik_path(poses, qs[0], tool_offset)
    assert failed == -1
    assert q.shape == (len(poses), 6)
    ref, ref_failed = _sequential(poses, qs[0], tool_offset)
    assert ref_failed == -1
    np.testing.assert_allclose(q, ref, rtol=0.0, atol=1e-12)
    # Nearest the previous solution along a smooth path: the path it came from.
    np.testing.assert_allclose(q, qs, atol=1e-6)
    _assert_fk_reproduces(q, poses, tool_offset)


@pytest.mark.parametrize(
    "q_start",
    [HOME_QPOS, HOME_QPOS + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 2 * np.pi])],  # other turn of the wrist
    ids=["home", "wrist-turned"],
)
def test_straight_line_matches_the_sequential_loop(q_start: np.ndarray) -> None:
    start = fk_tcp(q_start)
    poses = _line(start, _shifted(start, (0.12, -0.18, -0.10), yaw=0.6))
    q, failed = ik_path(poses, q_start, TCP_OFFSET)
    assert failed == -1
    ref, _ = _sequential(poses, q_start, TCP_OFFSET)
    np.testing.assert_allclose(q, ref, rtol=0.0, atol=1e-12)
    _assert_fk_reproduces(q, poses, TCP_OFFSET)
    # Continuous: small steps between neighbours, the first one near the start, in the limits.
    assert np.max(np.abs(q[0] - q_start)) < 1e-6
    assert np.max(np.abs(np.diff(q, axis=0))) < 0.1
    assert np.all(q >= JOINT_LIMITS[:, 0]) and np.all(q <= JOINT_LIMITS[:, 1])
    # The representation of the start is kept (no 2π jump to the other turn).
    assert abs(q[-1, 5] - q_start[5]) < np.pi


@pytest.mark.parametrize("where", ["first", "middle", "last"])
def test_unreachable_pose_returns_its_index(where: str) -> None:
    start = fk_tcp(HOME_QPOS)
    poses = _line(start, _shifted(start, (0.10, 0.15, 0.05), yaw=-0.4), n=30)
    k = {"first": 0, "middle": 13, "last": len(poses) - 1}[where]
    poses[k, :3, 3] = _FAR
    q, failed = ik_path(poses, HOME_QPOS, TCP_OFFSET)
    assert failed == k
    ref, ref_failed = _sequential(poses, HOME_QPOS, TCP_OFFSET)
    assert ref_failed == k
    # The rows before the failure are defined and equal the loop's.
    np.testing.assert_allclose(q[:k], ref, rtol=0.0, atol=1e-12)
    _assert_fk_reproduces(q[:k], poses[:k], TCP_OFFSET)


def test_pose_outside_tight_limits_fails_like_the_loop() -> None:
    # The same line with the base joint's range cut in the middle of the motion.
    start = fk_tcp(HOME_QPOS)
    poses = _line(start, _shifted(start, (0.0, 0.25, 0.0), yaw=0.0), n=40)
    free, failed = ik_path(poses, HOME_QPOS, TCP_OFFSET)
    assert failed == -1
    # Joint 0 (the base pan) sweeps monotonically; allow only its first half (both bounds narrowed, so
    # that no other turn of the joint fits either).
    assert np.all(np.diff(free[:, 0]) > 0) or np.all(np.diff(free[:, 0]) < 0)
    limits = JOINT_LIMITS.copy()
    cut = float(np.median(free[:, 0]))
    q0 = float(free[0, 0])
    limits[0] = (q0 - 0.05, cut) if cut > q0 else (cut, q0 + 0.05)
    q, failed = ik_path(poses, HOME_QPOS, TCP_OFFSET, limits)
    ref, ref_failed = _sequential(poses, HOME_QPOS, TCP_OFFSET, limits)
    assert 0 < failed < len(poses)
    assert failed == ref_failed
    np.testing.assert_allclose(q[:failed], ref, rtol=0.0, atol=1e-12)
    assert np.all(q[:failed] >= limits[:, 0]) and np.all(q[:failed] <= limits[:, 1])


def test_bad_shapes_raise_kinematics_error() -> None:
    pose = fk_tcp(HOME_QPOS)
    with pytest.raises(KinematicsError):
        ik_path(pose, HOME_QPOS, TCP_OFFSET)  # one pose, not a sequence
    with pytest.raises(KinematicsError):
        ik_path(pose[None], HOME_QPOS[:5], TCP_OFFSET)
    bad = pose[None].copy()
    bad[0, 0, 3] = np.nan
    with pytest.raises(KinematicsError):
        ik_path(bad, HOME_QPOS, TCP_OFFSET)
