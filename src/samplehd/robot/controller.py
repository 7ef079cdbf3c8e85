"""Robot control asynchronous to physics.

A policy or planner decides at the control rate (20 Hz by default); physics runs at its own rate
(500 Hz). Each decision sets a joint-space target; until the next decision the joint position
servos follow a target that ramps linearly towards it, within the joint speed limits, so motion is
continuous. The ramp runs inside MuJoCo (integrated-velocity servos, see
:mod:`samplehd.robot.ur5e`): one control step is a handful of ``mj_step(model, data, nstep)``
calls, with a safety check between them.

Action modes (``mode`` argument) and the layout of ``action`` (all in the robot base frame):

=================  =====  ======================================================================
mode               shape  meaning
=================  =====  ======================================================================
``joint_position``  (7,)  6 joint targets [rad], gripper
``joint_delta``     (7,)  6 joint target increments [rad] (clipped to ``max_joint_delta``), gripper
``cartesian_pose``  (8,)  TCP position [m] (3), TCP orientation quaternion w, x, y, z (4), gripper
``cartesian_delta`` (7,)  TCP translation [m] (3) and rotation vector [rad] (3) for this step, gripper
``steering``        (7,)  SAMPLE-HD steering: TCP linear velocity x, y, z and angular velocity x, y, z
                          in [-1, 1], scaled by ``max_linear_speed`` / ``max_angular_speed``, gripper
=================  =====  ======================================================================

The gripper value is in [-1, 1]: +1 fully open (85 mm), -1 closed (squeezing with the limited grip
force), linear in between. Values out of range are clipped and the clipping is reported; NaN,
infinities, wrong shapes and unknown modes raise :class:`~samplehd.errors.ActionError`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from samplehd.errors import ActionError, ConfigError, UnreachableError
from samplehd.physics import wake_all
from samplehd.robot.constants import (
    GRIPPER_ACTUATOR,
    GRIPPER_STROKE,
    JOINT_LIMITS,
    JOINT_NAMES,
    NUM_JOINTS,
    POSITION_ACTUATORS,
    ROBOT_BODY,
    SPEED_LIMITS,
    TCP_OFFSET,
    VELOCITY_ACTUATORS,
)
from samplehd.robot.kinematics import fk_tcp, ik_nearest_rows
from samplehd.robot.safety import SafetyConfig, SafetyEvent, SafetyMonitor
from samplehd.schema import Config, bounded

__all__ = ["ACTION_MODES", "ControlConfig", "ControlReport", "RobotController"]

ACTION_MODES: dict[str, int] = {
    "joint_position": 7,
    "joint_delta": 7,
    "cartesian_pose": 8,
    "cartesian_delta": 7,
    "steering": 7,
}


@dataclass(frozen=True)
class ControlConfig(Config, section="ControlConfig"):
    """Rates and limits of the controller.

    Attributes:
        physics_hz: physics rate; must equal 1 / model timestep [Hz].
        control_hz: decision rate; physics_hz must be a multiple of it [Hz].
        max_linear_speed: TCP speed for a steering value of 1 [m/s].
        max_angular_speed: TCP angular speed for a steering value of 1 [rad/s].
        max_joint_delta: largest joint increment per control step in ``joint_delta`` mode [rad].
        max_cartesian_delta: largest TCP translation / rotation per step in ``cartesian_delta``
            mode [m, rad].
        speed_scale: fraction of the UR5e joint speed limits (180°/s) the target may move at (0, 1].
        safety_checks_per_step: how many times per control step the safety monitor checks
            contacts (the physics steps are split into that many equal chunks; must divide them);
            joint torques are sampled once per control step.
        raise_unreachable: raise UnreachableError for an unreachable Cartesian command instead of
            holding the previous target and reporting it.
        safety: safety monitor thresholds; None disables the monitor.
    """

    physics_hz: float = bounded(500.0, lo=0.0, lo_open=True, unit="Hz")
    control_hz: float = bounded(20.0, lo=0.0, lo_open=True, unit="Hz")
    max_linear_speed: float = bounded(0.25, lo=0.0, lo_open=True, unit="m/s")
    max_angular_speed: float = bounded(1.0, lo=0.0, lo_open=True, unit="rad/s")
    max_joint_delta: float = bounded(0.15, lo=0.0, lo_open=True, unit="rad")
    # [m, rad]
    max_cartesian_delta: tuple[float, float] = bounded((0.05, 0.25), lo=0.0, lo_open=True)
    speed_scale: float = bounded(1.0, lo=0.0, lo_open=True, hi=1.0)
    safety_checks_per_step: int = bounded(5, lo=1)
    raise_unreachable: bool = False
    safety: SafetyConfig | None = field(default_factory=SafetyConfig)

    def __post_init__(self) -> None:
        super().__post_init__()
        ratio = self.physics_hz / self.control_hz
        if ratio < 1 or abs(ratio - round(ratio)) > 1e-9:
            raise ConfigError(f"ControlConfig.physics_hz={self.physics_hz!r}: must be an integer multiple of "
                              f"control_hz ({self.control_hz}), e.g. 500 and 20")
        if self.substeps % self.safety_checks_per_step:
            raise ConfigError(f"ControlConfig.safety_checks_per_step={self.safety_checks_per_step!r}: must divide "
                              f"the {self.substeps} physics steps per control step")

    @property
    def substeps(self) -> int:
        """Physics steps per control step."""
        return round(self.physics_hz / self.control_hz)

    @property
    def control_dt(self) -> float:
        """Control period [s]."""
        return self.substeps / self.physics_hz


@dataclass(frozen=True)
class ControlReport:
    """What happened in one control step.

    Attributes:
        time: simulation time at the end of the step [s].
        clipped: names of the action fields that were out of range and clipped (e.g. "gripper",
            "joint_position", "steering", "joint_limits").
        unreachable: the Cartesian command had no IK solution; the previous target was kept.
        ignored: the command was ignored because the arm is stopped by the safety monitor.
        safety_event: the event that stopped the arm during this step, if any.
    """

    time: float
    clipped: tuple[str, ...] = ()
    unreachable: bool = False
    ignored: bool = False
    safety_event: SafetyEvent | None = None


def _as_index(indices: list[int]) -> slice | np.ndarray:
    """A slice for consecutive indices, else an index array."""
    if all(b == a + 1 for a, b in zip(indices, indices[1:])):  # noqa: B905
        return slice(indices[0], indices[-1] + 1)
    return np.asarray(indices)


def _rotvec_rows(rotvec: list[float]) -> list[list[float]]:
    """Rotation matrix (rows) of a non-zero rotation vector (Rodrigues) [rad]."""
    angle = math.sqrt(rotvec[0] ** 2 + rotvec[1] ** 2 + rotvec[2] ** 2)
    if angle < 1e-15:
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    kx, ky, kz = rotvec[0] / angle, rotvec[1] / angle, rotvec[2] / angle
    s, c = math.sin(angle), math.cos(angle)
    t = 1.0 - c
    return [
        [c + t * kx * kx, t * kx * ky - s * kz, t * kx * kz + s * ky],
        [t * kx * ky + s * kz, c + t * ky * ky, t * ky * kz - s * kx],
        [t * kx * kz - s * ky, t * ky * kz + s * kx, c + t * kz * kz],
    ]


class RobotController:
    """Drives the UR5e of a compiled world through the control modes in :data:`ACTION_MODES`.

    Args:
        model: compiled world with the robot (built with :func:`samplehd.robot.ur5e.add_robot`).
        data: its data; the controller writes ``ctrl`` and ``act`` of the robot actuators.
        config: rates and limits.

    The controller starts from the servos' current targets (``data.act``); on fresh data (where
    they are zero) call :meth:`reset` first, which holds the arm where it is or at a given pose.

    Example:
        >>> ctrl = RobotController(model, data)          # doctest: +SKIP
        >>> ctrl.reset(HOME_QPOS)                          # doctest: +SKIP
        >>> report = ctrl.step(np.r_[0.5, 0, 0, 0, 0, 0, -1.0], "steering")  # doctest: +SKIP
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, config: ControlConfig | None = None) -> None:
        self.model = model
        self.data = data
        self.config = config or ControlConfig()
        cfg = self.config
        if abs(model.opt.timestep * cfg.physics_hz - 1.0) > 1e-9:
            raise ConfigError(
                f"model timestep {model.opt.timestep} s does not match ControlConfig.physics_hz {cfg.physics_hz}; "
                f"set spec.option.timestep = {1.0 / cfg.physics_hz}"
            )
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, ROBOT_BODY) < 0:
            raise ConfigError(f"model has no body {ROBOT_BODY!r}; build the world with samplehd.robot.ur5e.add_robot")
        # Index sets are slices when contiguous (they are for add_robot's layout): slicing costs
        # far less than fancy indexing in the per-step path.
        self._qpos_idx = _as_index([model.jnt_qposadr[model.joint(j).id] for j in JOINT_NAMES])
        self._dof_idx = _as_index([model.jnt_dofadr[model.joint(j).id] for j in JOINT_NAMES])
        pos_ids = [model.actuator(a).id for a in POSITION_ACTUATORS]
        vel_ids = [model.actuator(a).id for a in VELOCITY_ACTUATORS]
        self._ctrl_idx = _as_index(pos_ids + vel_ids)
        self._pos_ctrl = _as_index(pos_ids)
        self._vel_ctrl = _as_index(vel_ids)
        self._act_idx = _as_index(model.actuator_actadr[pos_ids].tolist())
        self._gripper_id = model.actuator(GRIPPER_ACTUATOR).id
        self._speed = SPEED_LIMITS * cfg.speed_scale
        self._reach = self._speed * cfg.control_dt  # largest target move per control step [rad]
        self._limits = JOINT_LIMITS
        self._lo, self._hi = JOINT_LIMITS[:, 0].copy(), JOINT_LIMITS[:, 1].copy()
        self._limit_rows = JOINT_LIMITS.tolist()
        self._dt = cfg.control_dt
        self._chunk = cfg.substeps // cfg.safety_checks_per_step
        self.monitor = SafetyMonitor(model, cfg.safety) if cfg.safety is not None else None
        # Start from the servos' current target (data.act is part of the physics state, so a
        # restored state resumes its ramp); call reset() to hold the measured pose instead.
        self._target = self.data.act[self._act_idx].copy()
        # TCP pose of the target when it came from a Cartesian command (saves an FK per step).
        self._target_pose: list[list[float]] | None = None
        self._stopped: SafetyEvent | None = None
        self._zero_ctrl = np.zeros(2 * NUM_JOINTS)

    # ------------------------------------------------------------------ state
    def joint_positions(self) -> np.ndarray:
        """Measured arm joint angles [rad]."""
        return self.data.qpos[self._qpos_idx].copy()

    def joint_velocities(self) -> np.ndarray:
        """Measured arm joint velocities [rad/s]."""
        return self.data.qvel[self._dof_idx].copy()

    @property
    def target(self) -> np.ndarray:
        """Joint target of the latest command [rad] (the servos ramp towards it)."""
        return self._target.copy()

    @property
    def interpolated_target(self) -> np.ndarray:
        """Current point of the ramp, i.e. what the position servos track right now [rad]."""
        return self.data.act[self._act_idx].copy()

    @property
    def gripper_width(self) -> float:
        """Commanded finger opening [m]."""
        return float(self.data.ctrl[self._gripper_id])

    @property
    def stopped(self) -> SafetyEvent | None:
        """The safety event that stopped the arm, or None while it may move."""
        return self._stopped

    def tcp_pose(self) -> np.ndarray:
        """TCP pose of the current joint target in the base frame (4×4) [m]."""
        return fk_tcp(self._target)

    # ------------------------------------------------------------------ commands
    def reset(self, qpos: np.ndarray | None = None, gripper: float = 1.0) -> None:
        """Clear a safety stop and hold the arm still.

        Args:
            qpos: if given, teleport the arm to these joint angles [rad] (zero velocity); otherwise
                hold where it is.
            gripper: gripper command in [-1, 1] (+1 open).
        """
        d = self.data
        if qpos is not None:
            q = np.asarray(qpos, dtype=float)
            if q.shape != (NUM_JOINTS,) or not np.all(np.isfinite(q)):
                raise ActionError(f"reset qpos must be 6 finite joint angles [rad], got shape {q.shape}")
            d.qpos[self._qpos_idx] = np.clip(q, self._limits[:, 0], self._limits[:, 1])
            d.qvel[self._dof_idx] = 0.0
        self._hold()
        self._stopped = None
        if self.monitor is not None:
            self.monitor.reset()
        self._set_gripper(np.clip(gripper, -1.0, 1.0))
        mujoco.mj_forward(self.model, d)

    def _hold(self) -> None:
        q = self.data.qpos[self._qpos_idx]
        self._target = q.copy()
        self._target_pose = None
        self.data.act[self._act_idx] = q
        self.data.ctrl[self._ctrl_idx] = self._zero_ctrl

    def _set_gripper(self, command: float) -> None:
        width = (command + 1.0) * 0.5 * GRIPPER_STROKE
        if width > self.data.ctrl[self._gripper_id] + 1e-6:
            # Opening releases whatever the fingers held; wake it so that it falls.
            wake_all(self.data)
        self.data.ctrl[self._gripper_id] = width

    def command(self, action: np.ndarray, mode: str = "joint_position") -> ControlReport:
        """Set a new target from an action without stepping physics; see the module docstring.

        Returns:
            A report (time is the current time).

        Raises:
            ActionError: unknown mode, wrong shape, NaN or infinite values.
            UnreachableError: only with ``raise_unreachable`` and an unreachable Cartesian command.
        """
        size = ACTION_MODES.get(mode)
        if size is None:
            raise ActionError(f"unknown action mode {mode!r}; valid: {', '.join(ACTION_MODES)}")
        a = np.asarray(action, dtype=float)
        if a.shape != (size,):
            raise ActionError(f"action for mode {mode!r} must have shape ({size},), got {a.shape}")
        values = a.tolist()
        if not all(map(math.isfinite, values)):
            raise ActionError(f"action for mode {mode!r} contains NaN or infinite values")
        if self._stopped is not None:
            return ControlReport(time=float(self.data.time), ignored=True)
        clipped: list[str] = []
        gripper = a[-1]
        if not -1.0 <= gripper <= 1.0:
            clipped.append("gripper")
            gripper = min(1.0, max(-1.0, gripper))
        unreachable = False
        pose = None
        if mode == "joint_position":
            target = a[:6]
            # within the joint limits (the usual case): compared on Python floats, kept as given
            if all(lo <= q <= hi for q, (lo, hi) in zip(values[:6], self._limit_rows, strict=True)):
                self._target = target.copy()
                self._target_pose = None
                self._set_gripper(gripper)
                return ControlReport(time=float(self.data.time), clipped=tuple(clipped))
        elif mode == "joint_delta":
            delta = a[:6]
            lim = self.config.max_joint_delta
            if np.any(np.abs(delta) > lim):
                clipped.append("joint_delta")
                delta = np.clip(delta, -lim, lim)
            target = self._target + delta
        else:
            target, pose, unreachable, cart_clipped = self._cartesian_target(a, mode)
            clipped.extend(cart_clipped)
        lo, hi = self._lo, self._hi
        if (target < lo).any() or (target > hi).any():
            clipped.append("joint_limits")
            target = np.clip(target, lo, hi)
        self._target = np.array(target, dtype=float)
        self._target_pose = pose
        self._set_gripper(gripper)
        return ControlReport(time=float(self.data.time), clipped=tuple(clipped), unreachable=unreachable)

    def _cartesian_target(
        self, a: np.ndarray, mode: str
    ) -> tuple[np.ndarray, list[list[float]] | None, bool, list[str]]:
        """Joint target, its TCP pose rows, unreachable flag, clipped fields.

        Small 3×3 algebra runs on Python floats: for single poses it is several times cheaper
        than numpy, and this runs once per control step.
        """
        clipped: list[str] = []
        if mode == "cartesian_pose":
            w, x, y, z = a[3:7].tolist()
            norm = math.sqrt(w * w + x * x + y * y + z * z)
            if norm < 1e-9:
                raise ActionError("cartesian_pose quaternion (action[3:7]) must be non-zero (w, x, y, z)")
            w, x, y, z = w / norm, x / norm, y / norm, z / norm
            px, py, pz = a[:3].tolist()
            rows = [
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y), px],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x), py],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y), pz],
            ]
        else:
            current = self._target_pose
            if current is None:
                current = fk_tcp(self._target)[:3].tolist()
            if mode == "steering":
                twist = a[:6]
                if np.any(np.abs(twist) > 1.0):
                    clipped.append("steering")
                    twist = np.clip(twist, -1.0, 1.0)
                lin = (twist[:3] * (self.config.max_linear_speed * self._dt)).tolist()
                rot = (twist[3:] * (self.config.max_angular_speed * self._dt)).tolist()
            else:
                lin, rot = a[:3].tolist(), a[3:6].tolist()
                max_lin, max_rot = self.config.max_cartesian_delta
                n_lin, n_rot = math.hypot(*lin), math.hypot(*rot)
                if n_lin > max_lin:
                    lin = [v * (max_lin / n_lin) for v in lin]
                    clipped.append("cartesian_delta")
                if n_rot > max_rot:
                    rot = [v * (max_rot / n_rot) for v in rot]
                    clipped.append("cartesian_delta")
            # Velocities are in the base frame; rotation is about the TCP.
            rows = [[r[0], r[1], r[2], r[3] + d] for r, d in zip(current, lin)]  # noqa: B905
            if any(rot):
                rmat = _rotvec_rows(rot)
                cols = [[r[j] for r in current] for j in range(3)]
                for i in range(3):
                    ri = rmat[i]
                    for j in range(3):
                        c = cols[j]
                        rows[i][j] = ri[0] * c[0] + ri[1] * c[1] + ri[2] * c[2]
        best = ik_nearest_rows(rows, self._target.tolist(), TCP_OFFSET, self._limit_rows)
        if best is None:
            if self.config.raise_unreachable:
                p = rows
                raise UnreachableError(
                    f"TCP pose at ({p[0][3]:.3f}, {p[1][3]:.3f}, {p[2][3]:.3f}) m in the base frame is out of "
                    "reach of the UR5e within its joint limits"
                )
            return self._target.copy(), self._target_pose, True, clipped
        return np.array(best), rows, False, clipped

    # ------------------------------------------------------------------ stepping
    def advance(self) -> SafetyEvent | None:
        """Run one control period of physics, ramping towards the current target.

        Returns:
            The safety event that stopped the arm during this period, if any.
        """
        m, d = self.model, self.data
        act = self._act_idx
        pinned = False
        if self._stopped is None:
            ramp = self._target - d.act[act]
            # Synchronised straight line in joint space: every joint's ramp is scaled by the same
            # factor, so the slowest joint (at its speed limit) sets the pace and all joints
            # arrive together, as a UR "movej" does. The target is reached this period when the
            # speed limits allow.
            slowest = float((np.abs(ramp) / self._reach).max())
            fraction = 1.0 if slowest <= 1.0 else 1.0 / slowest
            velocity = ramp * (fraction / self._dt)
            d.ctrl[self._pos_ctrl] = velocity
            d.ctrl[self._vel_ctrl] = velocity
            pinned = fraction == 1.0
        event = None
        monitor = self.monitor
        chunk = self._chunk
        last = self.config.safety_checks_per_step - 1
        for k in range(last + 1):
            mujoco.mj_step(m, d, chunk)
            if monitor is not None and self._stopped is None:
                event = monitor.check(d, torque=k == last)
                if event is not None:
                    self._stopped = event
                    self._hold()
        if self._stopped is None:
            if pinned:
                # The ramp ended exactly at the target; pin it so that rounding in MuJoCo's
                # integration of the ramp does not accumulate.
                d.act[act] = self._target
            d.ctrl[self._ctrl_idx] = self._zero_ctrl
        return event

    def step(self, action: np.ndarray, mode: str = "joint_position") -> ControlReport:
        """Apply an action (:meth:`command`) and run one control period of physics (:meth:`advance`)."""
        report = self.command(action, mode)
        event = self.advance()
        return ControlReport(
            time=float(self.data.time),
            clipped=report.clipped,
            unreachable=report.unreachable,
            ignored=report.ignored,
            safety_event=event,
        )
