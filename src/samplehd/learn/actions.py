"""What the policies' outputs mean as steering vectors, and the labels the behaviour-cloning policy learns
from (shared by :mod:`samplehd.learn.policy` and :mod:`samplehd.learn.keypose`).

Steering (SAMPLE-HD's 7-D vectors): the recorded vectors of every frame but the waits
(:func:`moving_frames`). Waypoints: a demonstration cut into segments whose end states are the
waypoints (:func:`waypoints`); the network writes the displacement to the waypoint
(:func:`waypoint_targets`), and a follower turns it into a steering vector. :class:`WaypointExpert`
labels any state of an episode with its waypoint (the DAgger labeller), and
:func:`follow_waypoints` drives an environment through a demonstration's waypoints.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from samplehd.learn.demos import squeeze_command

__all__ = ["WaypointExpert", "follow_waypoints", "moving_frames", "rotation_columns", "steering_speeds", "tcp_yaw",
           "waypoint_steering", "waypoint_targets", "waypoints", "wrap_angle"]

# Waypoint actions: the network writes the displacement to the waypoint divided by this [m] ...
WAYPOINT_SCALE = 0.3
# ... and a frame this close to its segment's end (position [m], yaw [rad], finger opening [m]) is
# labelled with the next segment's waypoint: the switch a waypoint follower makes.
WAYPOINT_REACHED = (0.004, 0.05, 0.002)
WAYPOINT_AHEAD = 0.05  # the waypoint of a motion the episode's end cut short lies this far ahead [m]
WAYPOINT_GAIN = 3.0  # TCP velocity per metre of the remaining displacement [1/s]
WAYPOINT_SPEED = 0.16  # largest TCP speed of the waypoint follower [m/s]
YAW_GAIN = 3.0  # yaw rate per radian of the remaining yaw [1/s]
CLOSE_BELOW = -0.9  # a predicted gripper command below this closes the gripper (the label is -1)


def moving_frames(steering: np.ndarray, tolerance: float = 1e-3) -> np.ndarray:
    """Indices of the frames a policy learns from: every frame but the waits.

    A wait is a frame whose TCP velocity is zero and whose gripper command equals the previous
    frame's (the demonstrations hold still between subtasks). Its observation looks like its
    neighbours', so a policy cannot tell how long to wait and imitating it stalls; leaving the
    waits out makes the next motion the label of the frame before it.
    """
    steering = np.asarray(steering, np.float64)
    still = np.abs(steering[:, :6]).max(axis=1) < tolerance
    same_grip = np.r_[False, np.abs(np.diff(steering[:, 6])) < tolerance]
    keep = ~(still & same_grip)
    keep[0] = True
    return np.flatnonzero(keep)

def rotation_columns(quat: np.ndarray) -> np.ndarray:
    """The first two columns of the rotation matrix of quaternions (..., 4: w x y z), as (..., 6).

    Unlike the quaternion, they do not change sign between q and -q, and are continuous in the pose.
    """
    q = np.asarray(quat, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y),
                     2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)], axis=-1)


def tcp_yaw(quat: np.ndarray) -> np.ndarray:
    """The heading of the TCP's x axis about the world z axis [rad]."""
    cols = rotation_columns(quat)
    return np.arctan2(cols[..., 1], cols[..., 0])


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """``angle`` wrapped into [-pi, pi) [rad]."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def waypoints(steering: np.ndarray, tcp_pos: np.ndarray, tcp_quat: np.ndarray, opening: np.ndarray,
              tolerance: float = 1e-3) -> np.ndarray:
    """Per frame of an episode, its waypoint (T, 5): TCP position (3, world) [m], yaw [rad] and the
    gripper there (+1 open, -1 closed).

    The demonstration is cut into segments: runs of frames that move the TCP (cut where it all but
    stops and sets off again), and runs that hold it and change the gripper command (the waits
    between them belong to no segment). A segment's waypoint is the state it ends in, read where the
    next one starts (the TCP has settled in the wait), with the gripper -1 (closing) after a segment
    that closes it, else the oracle's command at its end (the width it opened to). A frame's label
    is the waypoint of its segment, of the next segment once it is within :data:`WAYPOINT_REACHED`
    of its own (a wait's: the next segment's); after the last segment, the last waypoint
    (:data:`WAYPOINT_AHEAD` beyond the end of a motion the episode's end cut short). So a
    follower that goes to the predicted waypoint and switches where the demonstrations switch meets
    a label at every state on the way, and no label depends on time.
    """
    steering = np.asarray(steering, np.float64)
    tcp = np.asarray(tcp_pos, np.float64)
    yaw = tcp_yaw(tcp_quat)
    opening = np.asarray(opening, np.float64)
    n = len(steering)
    moving = np.abs(steering[:, :6]).max(axis=1) >= tolerance
    gripping = np.r_[False, np.abs(np.diff(steering[:, 6])) >= tolerance] & ~moving
    kind = np.where(moving, 1, np.where(gripping, 2, 0))
    # A motion also ends where the TCP all but stops and sets off again (a joint-space move to the
    # pre-grasp pose, then the straight descent).
    speed = np.sqrt((steering[:, :3] ** 2).sum(axis=1))
    cut = np.zeros(n, bool)
    cut[2:] = (speed[1:-1] < 0.05) & (speed[1:-1] <= speed[:-2]) & (speed[1:-1] < speed[2:])
    segments: list[tuple[int, int, int]] = []  # (first frame, last frame, kind)
    t = 0
    while t < n:
        if kind[t] == 0:
            t += 1
            continue
        e = t
        while e + 1 < n and kind[e + 1] == kind[t] and not cut[e + 1]:
            e += 1
        segments.append((t, e, int(kind[t])))
        t = e + 1
    out = np.empty((n, 5))
    if not segments:
        out[:, :3], out[:, 3], out[:, 4] = tcp, yaw, 1.0
        return out
    settled = [segments[j + 1][0] if j + 1 < len(segments) else n - 1 for j in range(len(segments))]
    # The gripper: -1 (close: squeeze_command) after a segment that closes it, else the oracle's
    # command (the width it opened to).
    closed, grippers = False, []
    for a, e, k in segments:
        change = steering[e, 6] - steering[max(a - 1, 0), 6]
        if k == 2 and abs(change) >= tolerance:
            closed = bool(change < 0)
        grippers.append(-1.0 if closed else float(steering[e, 6]))
    goal = np.array([[*tcp[f], yaw[f], g] for f, g in zip(settled, grippers, strict=True)])
    last = segments[-1]
    if last[2] == 1 and last[1] == n - 1:
        # The episode ended while this segment moved (the environment ends a successful episode at once,
        # in the middle of the lift): its waypoint lies ahead, where the motion was heading.
        heading = steering[n - 1, :3] / max(float(np.sqrt((steering[n - 1, :3] ** 2).sum())), 1e-9)
        goal[-1, :3] = tcp[n - 1] + WAYPOINT_AHEAD * heading
    pos_tol, yaw_tol, open_tol = WAYPOINT_REACHED

    def reached(t: int, j: int) -> bool:
        if segments[j][2] == 1:
            return bool(np.linalg.norm(goal[j, :3] - tcp[t]) < pos_tol
                        and abs(wrap_angle(goal[j, 3] - yaw[t])) < yaw_tol)
        return bool(abs(opening[settled[j]] - opening[t]) < open_tol)

    j = 0
    for t in range(n):
        while j < len(segments) and t > segments[j][1]:
            j += 1
        k = j
        while k < len(segments) and t >= segments[k][0] and reached(t, k):
            k += 1
        out[t] = goal[min(k, len(segments) - 1)]
    return out


class WaypointExpert:
    """The waypoints of one demonstration (rows of :func:`waypoints`, distinct, in order) as an expert
    for any state of its episode: :meth:`label` is the waypoint of the phase the arm is in, and the
    phase advances where the labels switch (within :data:`WAYPOINT_REACHED`; a closing waypoint once
    the fingers stop). A waypoint (the grasp pose the oracle chose, where it lifts to) does not depend
    on where the arm is, so the label of a state off the demonstration's path is still right: the
    DAgger labeller of the waypoint policy."""

    def __init__(self, goals: np.ndarray) -> None:
        self.goals = np.asarray(goals, np.float64)
        self.phase = 0
        self._opening: float | None = None

    @classmethod
    def of_episode(cls, steering: np.ndarray, tcp_pos: np.ndarray, tcp_quat: np.ndarray,
                   opening: np.ndarray) -> WaypointExpert:
        goal = waypoints(steering, tcp_pos, tcp_quat, opening)
        distinct = [goal[0]] + [g for a, g in zip(goal[:-1], goal[1:], strict=True) if np.abs(g - a).max() > 1e-9]
        return cls(np.array(distinct))

    def label(self, obs: Mapping[str, Any]) -> np.ndarray:
        """The waypoint for ``obs``, after advancing the phase on it."""
        goal = self.goals[self.phase]
        opening = float(obs["gripper"][0]) + float(obs["gripper"][1])
        closing = goal[4] < CLOSE_BELOW and (self.phase == 0 or self.goals[self.phase - 1][4] >= CLOSE_BELOW)
        if closing:
            reached = self._opening is not None and abs(opening - self._opening) < 1e-4
        else:
            pos_tol, yaw_tol, _ = WAYPOINT_REACHED
            reached = bool(np.linalg.norm(goal[:3] - np.asarray(obs["tcp_pos"], float)) < pos_tol
                           and abs(wrap_angle(goal[3] - tcp_yaw(np.asarray(obs["tcp_quat"], float)))) < yaw_tol)
        self._opening = opening
        if reached and self.phase < len(self.goals) - 1:
            self.phase += 1
        return self.goals[self.phase]

    def action(self, obs: Mapping[str, Any], goal: np.ndarray, speeds: tuple[float, float]) -> np.ndarray:
        """The follower's steering vector toward ``goal``."""
        target = waypoint_targets(goal[None], np.asarray(obs["tcp_pos"])[None], np.asarray(obs["tcp_quat"])[None])[0]
        return np.clip(waypoint_steering(target, obs["gripper"], speeds), -1.0, 1.0)


def follow_waypoints(env: Any, obs: Mapping[str, Any], goals: np.ndarray, max_steps: int) -> dict[str, Any]:
    """Drive the environment (reset by the caller, ``obs`` its observation) through ``goals``, the
    distinct waypoints of a demonstration of its episode, with the waypoint policy's follower and the
    switches of :class:`WaypointExpert`. What a perfect waypoint policy does: the check that the labels
    can be acted on. Returns the last step's info.
    """
    expert = WaypointExpert(goals)
    speeds = steering_speeds(env)
    info: dict[str, Any] = {}
    for _ in range(max_steps):
        action = expert.action(obs, expert.label(obs), speeds)
        obs, _, terminated, truncated, info = env.step(action.astype(np.float32))
        if terminated or truncated:
            break
    return info


def steering_speeds(env: Any) -> tuple[float, float]:
    """TCP speed and angular speed of a steering value of 1 in ``env`` [m/s, rad/s]."""
    control = getattr(getattr(env, "unwrapped", None), "control", None)
    if control is None:
        return (0.25, 1.0)
    return (float(control.max_linear_speed), float(control.max_angular_speed))


def waypoint_steering(out: np.ndarray, gripper: Any, speeds: tuple[float, float]) -> np.ndarray:
    """The steering vector that moves toward the waypoint ``out`` (:func:`waypoint_targets`): a TCP
    velocity of :data:`WAYPOINT_GAIN` times the displacement, at most :data:`WAYPOINT_SPEED`, a yaw rate
    of :data:`YAW_GAIN` times the remaining yaw; the gripper closing (:func:`squeeze_command`) where
    the predicted command is below :data:`CLOSE_BELOW`, else the predicted command."""
    lin_speed, ang_speed = speeds
    v = WAYPOINT_GAIN * WAYPOINT_SCALE * np.asarray(out[:3], np.float64)
    speed = float(np.sqrt((v * v).sum()))
    if speed > WAYPOINT_SPEED:
        v *= WAYPOINT_SPEED / speed
    action = np.zeros(7)
    action[:3] = v / lin_speed
    action[5] = YAW_GAIN * np.pi * float(out[5]) / ang_speed
    action[6] = squeeze_command(gripper) if out[6] < CLOSE_BELOW else float(out[6])
    return action


def waypoint_targets(goal: np.ndarray, tcp_pos: np.ndarray, tcp_quat: np.ndarray) -> np.ndarray:
    """The network's targets (T, 7) of frames with waypoints ``goal`` (:func:`waypoints`): the
    displacement to the waypoint over :data:`WAYPOINT_SCALE` (clipped to [-1, 1]), no roll or pitch,
    the remaining yaw over pi, the gripper command."""
    goal = np.asarray(goal, np.float64)
    out = np.zeros((len(goal), 7))
    out[:, :3] = np.clip((goal[:, :3] - np.asarray(tcp_pos, np.float64)) / WAYPOINT_SCALE, -1.0, 1.0)
    out[:, 5] = wrap_angle(goal[:, 3] - tcp_yaw(tcp_quat)) / np.pi
    out[:, 6] = goal[:, 4]
    return out.astype(np.float32)
