"""How the keypose policy acts on a decision (:class:`~samplehd.learn.keypose.processing.Decision`).

As in PerAct and CLIPort, a policy predicts a decision from one look at the table and
:class:`KeyposeFollower` executes it as steering vectors, step by step through the environment: over
the grasp at the height it is at, down, close until the fingers stop, up, over the goal, down, open,
up and back to the start pose. Its descents are guarded: one that stops short closes or opens there. A
grasp whose fingers close on nothing (:data:`MISSED_WIDTH`) goes back to the start pose open, and
:attr:`KeyposeFollower.missed` says so (the policy looks again).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from samplehd.learn.actions import steering_speeds, tcp_yaw, wrap_angle
from samplehd.learn.demos import squeeze_command
from samplehd.learn.keypose.processing import Decision
from samplehd.robot.constants import GRIPPER_STROKE

__all__ = ["APPROACH", "KeyposeFollower"]

APPROACH = 0.08  # the grasp and the release are approached straight down from this high above them [m]
REACHED = 0.004  # a position this close to its goal is reached [m] ...
YAW_REACHED = 0.05  # ... with the yaw this close [rad]
SETTLE_STEPS = 30  # a closing or opening gripper that has not settled after this many steps moves on
GAIN = 4.0  # TCP speed per metre, yaw rate per radian still to go [1/s]
MIN_SPEED = 0.03  # the TCP moves at least this fast until it is at its goal [m/s] ...
MAX_SPEED = 0.24  # ... and at most this fast (half of it near the table) [m/s]
OPEN_MARGIN = 0.01  # the gripper opens this much wider than the predicted opening before a grasp [m]
DESCENT_SPEED = 0.06  # the last approach to a grasp or release goes down at most this fast [m/s]
BLOCKED = 0.3  # a descent that moved less than this share of its commanded step has met something ...
BLOCKED_MIN_STEP = 0.001  # ... when the commanded step was at least this long [m]
MISSED_WIDTH = 0.001  # fingers that closed narrower than this hold nothing: the grasp missed [m]






def _command(opening: float) -> float:
    """The gripper command of a finger opening [m] (+1: the whole stroke, -1: closed)."""
    return float(np.clip(2.0 * opening / GRIPPER_STROKE - 1.0, -1.0, 1.0))


class KeyposeFollower:
    """Steering vectors that carry out one :class:`Decision` from the observation it was made on.

    The moves are straight lines of the TCP at the follower speed of the waypoint policy, each one
    over when the TCP is within :data:`REACHED` and :data:`YAW_REACHED` of its end; the grasp closes
    the fingers until they stop narrowing (they squeeze what they hold from then on), the release opens
    them until they stop widening. A move down toward the grasp or the release is guarded, as a robot's
    approach is: when the TCP goes down less than :data:`BLOCKED` of the step the last steering vector
    commanded, the descent has met the object or the table, and the fingers close (or open) at that
    height instead of pushing on to a contact-force stop. ``home``: the TCP position and yaw the arm
    goes back to after a release, where the next decision is made.
    """

    def __init__(self, decision: Decision, obs: Mapping[str, Any], home: np.ndarray, env: Any = None,
                 z_floor: float | None = None) -> None:
        d = decision
        gx, gy, gz, gyaw = d.grasp
        if z_floor is not None:
            gz = max(gz, z_floor)
        tcp = np.asarray(obs["tcp_pos"], np.float64)
        gyaw = _near_yaw(gyaw, float(tcp_yaw(np.asarray(obs["tcp_quat"], np.float64))))
        open_cmd = _command(d.opening + OPEN_MARGIN)
        over = max(float(tcp[2]), gz + APPROACH)
        steps: list[tuple[str, str, np.ndarray]] = [
            ("move", "over grasp", np.array([gx, gy, over, gyaw, open_cmd])),
            ("move", "over grasp", np.array([gx, gy, gz + APPROACH, gyaw, open_cmd])),
            ("move", "down to grasp", np.array([gx, gy, gz, gyaw, open_cmd])),
            ("close", "close", np.array([gx, gy, gz, gyaw, -1.0])),
            ("move", "lift", np.array([gx, gy, max(d.lift, gz), gyaw, -1.0])),
        ]
        px, py, pz, pyaw = d.goal
        pyaw = _near_yaw(pyaw, gyaw)
        if d.release:
            carry = max(d.lift, pz + APPROACH)
            steps += [("move", "carry", np.array([px, py, carry, pyaw, -1.0])),
                      ("move", "carry", np.array([px, py, pz + APPROACH, pyaw, -1.0])),
                      ("move", "down to release", np.array([px, py, pz, pyaw, -1.0])),
                      ("open", "open", np.array([px, py, pz, pyaw, open_cmd])),
                      ("move", "up", np.array([px, py, pz + APPROACH, pyaw, open_cmd]))]
            # back to where the camera sees the table, as the demonstrations do
            steps += [("move", "home", np.array([home[0], home[1], max(carry, home[2]), _near_yaw(home[3], pyaw),
                                                 open_cmd])),
                      ("move", "home", np.array([home[0], home[1], home[2], _near_yaw(home[3], pyaw), open_cmd]))]
        else:
            steps += [("move", "carry", np.array([px, py, max(pz, d.lift), pyaw, -1.0]))]
        self.steps = steps
        self.phase = 0
        self.missed = False  # the grasp closed on nothing; the follower went back home without carrying
        self._home_steps = [("move", "up", np.array([gx, gy, over, gyaw, open_cmd])),
                            ("move", "home", np.array([home[0], home[1], max(over, home[2]),
                                                       _near_yaw(home[3], gyaw), open_cmd])),
                            ("move", "home", np.array([home[0], home[1], home[2], _near_yaw(home[3], gyaw),
                                                       open_cmd]))]
        self._speeds = steering_speeds(env)
        control = getattr(getattr(env, "unwrapped", None), "control", None)
        self._hz = float(control.control_hz) if control is not None else 20.0
        self._low = min(gz, d.goal[2]) + APPROACH / 2
        self._width: float | None = None
        self._settle = 0
        self._held: float | None = None
        self._last_z: float | None = None
        self._drop = 0.0  # the TCP's descent commanded by the last steering vector [m]

    @property
    def done(self) -> bool:
        return self.phase >= len(self.steps)

    @property
    def stage(self) -> str:
        """What the follower is doing: "over grasp", "down to grasp", "close", "lift", "carry", "down to
        release", "open", "up", "home", or "done"."""
        return "done" if self.done else self.steps[self.phase][1]

    def __call__(self, obs: Mapping[str, Any]) -> np.ndarray:
        """The next steering vector (7,); once :attr:`done`, one that holds the arm still."""
        z = float(obs["tcp_pos"][2])
        if self._blocked(z):  # a guarded move: close (or open) where the descent met the object or table
            end = next(k for k in range(self.phase, len(self.steps)) if self.steps[k][0] != "move")
            for k in range(self.phase, end + 1):
                self.steps[k][2][2] = z
        self._last_z = z
        while not self.done and self._reached(obs):
            if self.steps[self.phase][0] == "close" and self._width is not None and self._width < MISSED_WIDTH:
                # nothing between the fingers: back home, open, where the policy looks again
                self.missed = True
                self.steps = self.steps[:self.phase + 1] + self._home_steps
            self.phase += 1
            self._width = None
            self._settle = 0
        kind, _, goal = self.steps[min(self.phase, len(self.steps) - 1)]
        if self.done:
            goal = goal.copy()
            goal[:3] = np.asarray(obs["tcp_pos"], np.float64)
        return self._steer(obs, goal)

    def _steer(self, obs: Mapping[str, Any], goal: np.ndarray) -> np.ndarray:
        """Toward ``goal``: a TCP velocity of :data:`GAIN` times the displacement, between
        :data:`MIN_SPEED` and :data:`MAX_SPEED` (slower within :data:`APPROACH` of the table, at most
        :data:`DESCENT_SPEED` on the way down to a grasp or release) and never
        past the goal in one control step; a yaw rate of :data:`GAIN` times the remaining yaw; the
        gripper squeezing for a closed goal, else at the goal's opening."""
        lin_speed, ang_speed = self._speeds
        tcp = np.asarray(obs["tcp_pos"], np.float64)
        delta = goal[:3] - tcp
        dist = float(np.linalg.norm(delta))
        action = np.zeros(7)
        if dist > 1e-9:
            top = MAX_SPEED if min(tcp[2], goal[2]) > self._low else MAX_SPEED / 2
            if self.stage.startswith("down to"):
                top = min(top, DESCENT_SPEED)
            speed = min(max(GAIN * dist, MIN_SPEED), top, dist * self._hz)
            action[:3] = delta / dist * speed / lin_speed
            self._drop = max(0.0, -float(delta[2]) / dist * speed / self._hz)
        else:
            self._drop = 0.0
        yaw = float(wrap_angle(goal[3] - tcp_yaw(np.asarray(obs["tcp_quat"], np.float64))))
        action[5] = np.clip(GAIN * yaw, -ang_speed, ang_speed) / ang_speed
        if goal[4] >= -0.99:
            action[6] = goal[4]
        elif self.steps[min(self.phase, len(self.steps) - 1)][0] == "close":
            action[6] = squeeze_command(obs["gripper"])
        else:  # holding at the width the fingers stopped at, as the demonstrations do (squeezing on through
            # the lift pushes the pads past the contact-force limit on heavy objects)
            if self._held is None:
                self._held = _command(float(obs["gripper"][0]) + float(obs["gripper"][1]))
            action[6] = self._held
        return np.clip(action, -1.0, 1.0).astype(np.float32)

    def _blocked(self, z: float) -> bool:
        """Whether a descent toward the grasp or the release has stopped short: the TCP (now at height
        ``z``) went down less than :data:`BLOCKED` of what the last steering vector commanded."""
        if self.done or self.stage not in ("over grasp", "down to grasp", "carry", "down to release") \
                or self._last_z is None:
            return False
        return self._drop >= BLOCKED_MIN_STEP and self._last_z - z < BLOCKED * self._drop

    def _reached(self, obs: Mapping[str, Any]) -> bool:
        kind, _, goal = self.steps[self.phase]
        if kind in ("close", "open"):
            width = float(obs["gripper"][0]) + float(obs["gripper"][1])
            settled = self._width is not None and abs(width - self._width) < 1e-4
            self._width = width
            self._settle += 1
            return (settled and self._settle > 2) or self._settle > SETTLE_STEPS
        tcp = np.asarray(obs["tcp_pos"], np.float64)
        yaw = float(tcp_yaw(np.asarray(obs["tcp_quat"], np.float64)))
        return bool(np.linalg.norm(goal[:3] - tcp) < REACHED and abs(wrap_angle(goal[3] - yaw)) < YAW_REACHED)


def _near_yaw(yaw: float, ref: float) -> float:
    """``yaw`` or ``yaw + pi``, whichever is nearer ``ref`` (the fingers are symmetric)."""
    a = float(wrap_angle(yaw - ref))
    if a > np.pi / 2:
        a -= np.pi
    elif a < -np.pi / 2:
        a += np.pi
    return ref + a

