"""How the keypose policy acts on a decision (:class:`~samplehd.learn.keypose.processing.Decision`).

As in PerAct and CLIPort, a policy predicts a decision from one look at the table and
:class:`KeyposeFollower` executes it as steering vectors, step by step through the environment: over
the grasp at the height it is at, down, close until the fingers stop, up, over the goal, down, open,
up and back to the start pose. Its descents are guarded: one that stops short closes or opens there.
The tool is held pointing straight down, as in every demonstration: an arm that starts tilted (the
robot start axis of a suite) is turned level from its first move on (:data:`TILT_TOLERANCE`).

It tells whether it still holds the object from what a robot feels, the fingers' width under the
commands it sends and the gripper's object detection (:meth:`KeyposeFollower._detects_object`), never
from the object's pose: a grasp whose fingers close on nothing (:data:`MISSED_WIDTH`) with no object
detected has missed; after the lift, before opening at the release and every :data:`HOLD_CHECK_PERIOD`
while holding at the end of a decision that does not let go, a grip check asks the fingers for
:data:`CHECK_SQUEEZE` less than the width they hold at, and fingers that narrow by more than
:data:`DROPPED_MARGIN` (or close below :data:`MISSED_WIDTH`) with no object detected hold nothing any
more: the object slipped out. An object the gripper detects between fingers that closed past it (a
pinch at an edge, a thin rim) is held: the environment's grasp assist carries it. Either way the
follower goes back to the start pose open, and :attr:`KeyposeFollower.lost` says where (the policy
looks again). A move toward the grasp that has
not come :data:`STUCK_PROGRESS` closer in :data:`STUCK_STEPS` control steps (a grasp out of the arm's
reach, or behind what the arm meets on the way) is given up the same way (``lost`` "reach").
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from samplehd.learn.actions import steering_speeds, tcp_yaw, wrap_angle
from samplehd.learn.demos import squeeze_command
from samplehd.learn.keypose.processing import Decision
from samplehd.robot.constants import GRIPPER_STROKE
from samplehd.world.transforms import quat_to_mat

__all__ = ["APPROACH", "CHECK_SQUEEZE", "DROPPED_MARGIN", "HOLD_CHECK_PERIOD", "LOST_AT", "MISSED_WIDTH",
           "STUCK_PROGRESS", "STUCK_STEPS", "TILT_TOLERANCE", "KeyposeFollower", "tool_tilt"]

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
# A grip check asks for this much less than the held width [m]: a bounded squeeze. Closing on (each
# command 2 mm narrower than the fingers) stops the arm on a contact force on heavy objects, and a fixed
# 2 or 3 mm squeeze of a welded 54 mm object did too (300-400 N on one pad)
CHECK_SQUEEZE = 0.001
DROPPED_MARGIN = 0.0005  # fingers that narrow by more than this during a grip check hold nothing [m]
HOLD_CHECK_PERIOD = 2.0  # holding at the end of a decision that does not let go, the grip is checked this often [s]
# A move toward the grasp that has not come this much closer to its goal [m] in this many control steps
# (2 s at 20 Hz) is given up: the arm goes back home and the policy looks again. The yaw still to turn
# counts at STUCK_YAW_SCALE metres per radian (a turn in place is progress too).
STUCK_PROGRESS = 0.001
STUCK_STEPS = 40
STUCK_YAW_SCALE = 0.05  # [m/rad]
# A tool axis found further than this from straight down is turned level at GAIN from then on [rad]; the
# arm's own tracking error (up to 0.013 rad carrying a thermos) is left alone.
TILT_TOLERANCE = 0.02
# where :attr:`KeyposeFollower.lost` found the fingers empty ("reach": the grasp was given up on the way)
LOST_AT = ("close", "lift", "release", "hold", "reach")


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
    height instead of pushing on to a contact-force stop. Grip checks (the module docstring) stand
    after the lift and before the opening, and are added every :data:`HOLD_CHECK_PERIOD` once a
    decision that does not let go is done; a check squeezes by at most :data:`CHECK_SQUEEZE` with the
    arm still, then holds at the width again. ``home``: the TCP position and yaw the arm goes back to
    after a release, after a missed grasp and after a lost object, where the next decision is made.
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
            ("check", "lift check", np.array([gx, gy, max(d.lift, gz), gyaw, -1.0])),
        ]
        px, py, pz, pyaw = d.goal
        pyaw = _near_yaw(pyaw, gyaw)
        if d.release:
            carry = max(d.lift, pz + APPROACH)
            steps += [("move", "carry", np.array([px, py, carry, pyaw, -1.0])),
                      ("move", "carry", np.array([px, py, pz + APPROACH, pyaw, -1.0])),
                      ("move", "down to release", np.array([px, py, pz, pyaw, -1.0])),
                      ("check", "release check", np.array([px, py, pz, pyaw, -1.0])),
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
        # where the fingers were found empty (one of LOST_AT), after which the follower went back home open
        self.lost: str | None = None
        self._release = d.release
        self._over = over
        self._home = np.asarray(home, np.float64)
        self._open = open_cmd
        self._speeds = steering_speeds(env)
        self._env = getattr(env, "unwrapped", None)
        control = getattr(self._env, "control", None)
        self._hz = float(control.control_hz) if control is not None else 20.0
        self._low = min(gz, d.goal[2]) + APPROACH / 2
        self._width: float | None = None
        self._settle = 0
        self._held: float | None = None  # the gripper command that holds the object ...
        self._held_width = 0.0  # ... at this width, where the close stopped [m]
        self._idle = 0  # control steps held still since the last grip check
        self._last_z: float | None = None
        self._drop = 0.0  # the TCP's descent commanded by the last steering vector [m]
        self._nearest = np.inf  # the current move's closest approach to its goal so far [m] ...
        self._stalled = 0  # ... and the control steps since it last came STUCK_PROGRESS closer
        self._level = False  # the tool was found tilted: it is turned level from then on

    @property
    def done(self) -> bool:
        return self.phase >= len(self.steps)

    @property
    def stage(self) -> str:
        """What the follower is doing: "over grasp", "down to grasp", "close", "lift", "lift check",
        "carry", "down to release", "release check", "open", "up", "hold check", "home", or "done"."""
        return "done" if self.done else self.steps[self.phase][1]

    @property
    def missed(self) -> bool:
        """Whether the follower went back home without the object (:attr:`lost` says where)."""
        return self.lost is not None

    def __call__(self, obs: Mapping[str, Any]) -> np.ndarray:
        """The next steering vector (7,); once :attr:`done`, one that holds the arm still (and the object,
        checking the grip now and then)."""
        z = float(obs["tcp_pos"][2])
        if self._blocked(z):  # a guarded move: close (or open) where the descent met the object or table
            end = next((k for k in range(self.phase, len(self.steps)) if self.steps[k][0] in ("close", "open")),
                       len(self.steps) - 1)
            for k in range(self.phase, end + 1):
                self.steps[k][2][2] = z
        self._last_z = z
        if self._stuck(obs):  # the grasp is out of reach: back home open, where the policy looks again
            self.lost = "reach"
            here = self.steps[self.phase][2].copy()
            here[:3] = np.asarray(obs["tcp_pos"], np.float64)
            self.steps = self.steps[:self.phase] + self._home_steps(here, self.lost)
            self._nearest, self._stalled = np.inf, 0
        if self.done and not self._release and self.lost is None:
            self._idle += 1
            if self._idle >= round(HOLD_CHECK_PERIOD * self._hz):
                self._idle = 0
                here = self.steps[-1][2].copy()
                here[:3] = np.asarray(obs["tcp_pos"], np.float64)
                self.steps.append(("check", "hold check", here))
        while not self.done and self._reached(obs):
            kind, name, goal = self.steps[self.phase]
            if kind in ("close", "check") and self._width is not None and self._empty(kind, self._width) \
                    and not self._detects_object():
                # nothing between the fingers: back home, open, where the policy looks again
                self.lost = "close" if kind == "close" else name.split()[0]
                self.steps = self.steps[:self.phase + 1] + self._home_steps(goal, self.lost)
            self.phase += 1
            self._width = None
            self._settle = 0
            self._nearest, self._stalled = np.inf, 0
        kind, _, goal = self.steps[min(self.phase, len(self.steps) - 1)]
        if self.done:
            kind = "hold"
            goal = goal.copy()
            goal[:3] = np.asarray(obs["tcp_pos"], np.float64)
        return self._steer(obs, goal, kind)

    def _empty(self, kind: str, width: float) -> bool:
        """Whether fingers settled at ``width`` [m] at the end of a close or a grip check hold nothing."""
        return width < MISSED_WIDTH or (kind == "check" and width < self._held_width - DROPPED_MARGIN)

    def _detects_object(self) -> bool:
        """The gripper's object detection (as a parallel gripper reports that its fingers stopped on an
        object): in this environment, whether its grasp assist holds an object. A close or grip check
        finds the fingers empty only when the gripper does not report one; without the environment's
        assist (no env, or ``grasp_assist`` off) the fingers' width alone decides."""
        assist = getattr(self._env, "assist", None)
        return assist is not None and int(getattr(assist, "active", -1)) >= 0

    def _home_steps(self, goal: np.ndarray, lost: str) -> list[tuple[str, str, np.ndarray]]:
        """Up from ``goal``, where the fingers were found empty (``lost``), then back to the start pose,
        open: from the close as high as the grasp was approached, from the release by :data:`APPROACH`
        as after a release, from the lift or the hold not at all (already lifted, perhaps at the edge of
        the arm's reach)."""
        x, y, z, yaw = goal[:4]
        up = {"close": self._over, "release": float(z) + APPROACH}.get(lost, float(z))
        home_yaw = _near_yaw(self._home[3], float(yaw))
        return [("move", "up", np.array([x, y, up, yaw, self._open])),
                ("move", "home", np.array([self._home[0], self._home[1], max(up, self._home[2]), home_yaw,
                                           self._open])),
                ("move", "home", np.array([self._home[0], self._home[1], self._home[2], home_yaw, self._open]))]

    def _steer(self, obs: Mapping[str, Any], goal: np.ndarray, kind: str) -> np.ndarray:
        """Toward ``goal``: a TCP velocity of :data:`GAIN` times the displacement, between
        :data:`MIN_SPEED` and :data:`MAX_SPEED` (slower within :data:`APPROACH` of the table, at most
        :data:`DESCENT_SPEED` on the way down to a grasp or release) and never
        past the goal in one control step; a yaw rate of :data:`GAIN` times the remaining yaw; the
        gripper at the goal's opening, or for a closed goal squeezing while the step (``kind``) is a
        close, :data:`CHECK_SQUEEZE` narrower than the held width in a grip check, else holding."""
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
        tilt = tool_tilt(obs["tcp_quat"])
        self._level = self._level or float(np.linalg.norm(tilt)) > TILT_TOLERANCE
        if self._level:
            action[3:5] = np.clip(GAIN * tilt[:2], -ang_speed, ang_speed) / ang_speed
        if goal[4] >= -0.99:
            action[6] = goal[4]
        elif kind == "close":
            action[6] = squeeze_command(obs["gripper"])
        else:  # holding at the width the fingers stopped at, as the demonstrations do (squeezing on through
            # the lift pushes the pads past the contact-force limit on heavy objects)
            if self._held is None:
                self._held_width = float(obs["gripper"][0]) + float(obs["gripper"][1])
                self._held = _command(self._held_width)
            action[6] = _command(self._held_width - CHECK_SQUEEZE) if kind == "check" else self._held
        return np.clip(action, -1.0, 1.0).astype(np.float32)

    def _blocked(self, z: float) -> bool:
        """Whether a descent toward the grasp or the release has stopped short: the TCP (now at height
        ``z``) went down less than :data:`BLOCKED` of what the last steering vector commanded."""
        if self.done or self.stage not in ("over grasp", "down to grasp", "carry", "down to release") \
                or self._last_z is None:
            return False
        return self._drop >= BLOCKED_MIN_STEP and self._last_z - z < BLOCKED * self._drop

    def _stuck(self, obs: Mapping[str, Any]) -> bool:
        """Whether the move toward the grasp (before anything is held) has not come
        :data:`STUCK_PROGRESS` closer to its goal (the yaw counted at :data:`STUCK_YAW_SCALE`) in
        :data:`STUCK_STEPS` control steps."""
        if self.done or self.lost is not None or self.stage not in ("over grasp", "down to grasp"):
            return False
        goal = self.steps[self.phase][2]
        yaw = abs(float(wrap_angle(goal[3] - tcp_yaw(np.asarray(obs["tcp_quat"], np.float64)))))
        dist = float(np.linalg.norm(goal[:3] - np.asarray(obs["tcp_pos"], np.float64))) + STUCK_YAW_SCALE * yaw
        if dist < self._nearest - STUCK_PROGRESS:
            self._nearest, self._stalled = dist, 0
            return False
        self._stalled += 1
        return self._stalled >= STUCK_STEPS

    def _reached(self, obs: Mapping[str, Any]) -> bool:
        kind, _, goal = self.steps[self.phase]
        if kind in ("close", "open", "check"):
            width = float(obs["gripper"][0]) + float(obs["gripper"][1])
            settled = self._width is not None and abs(width - self._width) < 1e-4
            self._width = width
            self._settle += 1
            return (settled and self._settle > 2) or self._settle > SETTLE_STEPS
        tcp = np.asarray(obs["tcp_pos"], np.float64)
        yaw = float(tcp_yaw(np.asarray(obs["tcp_quat"], np.float64)))
        return bool(np.linalg.norm(goal[:3] - tcp) < REACHED and abs(wrap_angle(goal[3] - yaw)) < YAW_REACHED)


def tool_tilt(quat: np.ndarray) -> np.ndarray:
    """The rotation vector (base frame, which has the world's axes) that turns the TCP's approach axis,
    its z (straight down at the start pose), to straight down: zero for a level tool [rad]."""
    approach = quat_to_mat(quat)[:, 2]
    axis = np.cross(approach, (0.0, 0.0, -1.0))
    sin = float(np.linalg.norm(axis))
    if sin < 1e-12:
        return np.zeros(3)
    return axis / sin * float(np.arctan2(sin, -approach[2]))


def _near_yaw(yaw: float, ref: float) -> float:
    """``yaw`` or ``yaw + pi``, whichever is nearer ``ref`` (the fingers are symmetric)."""
    a = float(wrap_angle(yaw - ref))
    if a > np.pi / 2:
        a -= np.pi
    elif a < -np.pi / 2:
        a += np.pi
    return ref + a

