"""Time-parameterised joint trajectories sampled at the control rate: joint-space moves and
straight-line Cartesian moves of the TCP (through analytic IK). Both start and stop smoothly: short
moves follow a minimum-jerk profile; long joint moves speed up smoothly, cruise at the speed limit
and slow down smoothly (a minimum-jerk move peaks at 1.875× its mean speed, so over a long distance
it spends most of its time well below the limit)."""

from __future__ import annotations

import math

import numpy as np

from samplehd.errors import PlanningError
from samplehd.fixedmath import half_turn_axis, matmul, norm
from samplehd.robot.constants import TCP_OFFSET
from samplehd.robot.kinematics import ik_path

__all__ = ["cartesian_path", "cruise_profile", "interpolate_pose", "joint_path", "min_jerk", "rotation_angle"]


def min_jerk(n: int) -> np.ndarray:
    """Progress s(t) in [0, 1] at n samples t = 1/n … 1 of a minimum-jerk profile."""
    t = np.arange(1, n + 1) / n
    t3 = t * t * t  # products, not ``**``: numpy's power is CPU-dispatched (see samplehd.fixedmath)
    return 10 * t3 - 15 * (t3 * t) + 6 * (t3 * t * t)


def cruise_profile(
    dist: float, max_speed: float, dt: float, min_time: float = 0.3, ramp_time: float = 0.6
) -> np.ndarray:
    """Progress s(t) in [0, 1] at the control steps of a move of length ``dist`` whose speed never
    exceeds ``max_speed``.

    Where it is quicker, the speed rises over ``ramp_time`` along a smoothstep (acceleration zero at
    both ends, so no jerk spike), cruises at the limit and falls the same way; otherwise (short moves,
    or ``ramp_time`` 0) it is a minimum-jerk profile of at least ``min_time``.
    """
    t_min_jerk = max(min_time, 1.875 * dist / max_speed)
    t_cruise = dist / max_speed + ramp_time
    if ramp_time <= 0 or t_cruise >= t_min_jerk:
        return min_jerk(max(1, int(np.ceil(t_min_jerk / dt))))
    n = int(np.ceil(t_cruise / dt))
    total = n * dt
    v = dist / (total - ramp_time)  # at most max_speed; ends exactly at dist on the last step

    def ramp_distance(tau: np.ndarray) -> np.ndarray:  # distance covered tau into a speed ramp
        u = np.clip(tau / ramp_time, 0.0, 1.0)
        u3 = u * u * u
        return v * ramp_time * (u3 - u3 * u / 2) + v * np.maximum(tau - ramp_time, 0.0)

    t = np.arange(1, n + 1) * dt
    s = np.where(t < total / 2, ramp_distance(t), dist - ramp_distance(total - t))
    return np.clip(s / dist, 0.0, 1.0)


def rotation_angle(r: np.ndarray) -> float:
    """Angle of a rotation matrix [rad]."""
    return math.acos(max(-1.0, min(1.0, (float(np.trace(r)) - 1.0) / 2.0)))


def _axis_angle(r: np.ndarray) -> np.ndarray:
    ang = rotation_angle(r)
    if ang < 1e-9:
        return np.zeros(3)
    v = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    s = norm(v)
    if s < 1e-9:  # angle near pi
        return half_turn_axis(r) * ang
    return v / s * ang


def _rodrigues(w: np.ndarray) -> np.ndarray:
    ang = norm(w)
    if ang < 1e-12:
        return np.eye(3)
    k = w / ang
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(ang) * kx + matmul((1 - np.cos(ang)) * kx, kx)


def interpolate_pose(a: np.ndarray, b: np.ndarray, s: float) -> np.ndarray:
    """Pose at progress s between 4×4 poses a and b (linear position, geodesic rotation)."""
    return _interpolate(a, b, _axis_angle(matmul(a[:3, :3].T, b[:3, :3])), s)


def _interpolate(a: np.ndarray, b: np.ndarray, turn: np.ndarray, s: float) -> np.ndarray:
    """:func:`interpolate_pose` given the rotation from a to b as a rotation vector ``turn`` (in a's frame),
    which a line's poses share."""
    t = np.eye(4)
    t[:3, 3] = a[:3, 3] + s * (b[:3, 3] - a[:3, 3])
    t[:3, :3] = matmul(a[:3, :3], _rodrigues(s * turn))
    return t


def joint_path(waypoints: np.ndarray, dt: float, max_speed: float, min_time: float = 0.3,
               ramp_time: float = 0.6) -> np.ndarray:
    """Targets at the control rate along a piecewise-linear joint path, each segment timed by
    :func:`cruise_profile` (it stops at every waypoint).

    Args:
        waypoints: (k, 6) joint configurations, the first being the current one [rad].
        dt: control period [s].
        max_speed: largest joint speed [rad/s].
        min_time: shortest duration of a segment [s].
        ramp_time: duration of the speed-up and of the slow-down of a long segment [s].

    Returns:
        (T, 6) targets, excluding the start, ending exactly at the last waypoint.
    """
    out = []
    for a, b in zip(waypoints[:-1], waypoints[1:], strict=False):
        dist = float(np.max(np.abs(b - a)))
        if dist < 1e-9:
            continue
        s = cruise_profile(dist, max_speed, dt, min_time, ramp_time)[:, None]
        out.append(a + s * (b - a))
    return np.concatenate(out) if out else np.zeros((0, 6))


def cartesian_path(
    start_pose: np.ndarray,
    end_pose: np.ndarray,
    q_start: np.ndarray,
    dt: float,
    speed: float,
    angular_speed: float = 1.0,
    min_time: float = 0.3,
    max_joint_step: float = 0.25,
    ramp_time: float = 0.0,
) -> np.ndarray:
    """Targets at the control rate moving the TCP along a straight line between base-frame poses.

    Args:
        start_pose: TCP pose at the start in the robot base frame (4×4).
        end_pose: TCP pose at the end (4×4).
        q_start: joint configuration at the start (IK seed) [rad].
        dt: control period [s].
        speed: mean linear speed of a minimum-jerk line [m/s]; its peak (1.875×) is the speed limit
            of a cruising line.
        angular_speed: mean angular speed [rad/s], likewise.
        min_time: shortest duration [s].
        max_joint_step: largest joint change between two targets [rad]; larger means an IK branch
            switch or a singularity.
        ramp_time: speed-up and slow-down time of a long line that cruises at the peak speed in
            between (:func:`cruise_profile`); 0 keeps minimum-jerk timing.

    Returns:
        (T, 6) joint targets, excluding the start.

    Raises:
        PlanningError: a pose on the line is out of reach or the joint path jumps.
    """
    dist = float(norm(end_pose[:3, 3] - start_pose[:3, 3]))
    ang = rotation_angle(matmul(start_pose[:3, :3].T, end_pose[:3, :3]))
    # The profile runs over the longer of the two motions, measured in seconds at their own speeds.
    length = max(dist / speed, ang / angular_speed)
    profile = cruise_profile(length, 1.875, dt, min_time, ramp_time) if length > 0 else min_jerk(
        max(1, int(np.ceil(min_time / dt))))
    turn = _axis_angle(matmul(start_pose[:3, :3].T, end_pose[:3, :3]))
    poses = np.stack([_interpolate(start_pose, end_pose, turn, float(s)) for s in profile])
    out, failed = ik_path(poses, q_start, TCP_OFFSET)
    if failed >= 0:
        p = poses[failed, :3, 3]
        raise PlanningError(f"straight TCP path leaves the reach at ({p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}) m")
    steps = np.abs(np.diff(np.vstack([np.asarray(q_start, float)[None], out]), axis=0))
    if steps.max(initial=0.0) > max_joint_step:
        raise PlanningError("straight TCP path crosses a singularity (joint jump)")
    return out
