"""Control asynchronous to physics: modes, continuity, speed limits, clipping and errors."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from robot_world import build_table_world

from samplehd.errors import ActionError, ConfigError, UnreachableError
from samplehd.robot.constants import GRIPPER_STROKE, HOME_QPOS, JOINT_LIMITS, SPEED_LIMITS
from samplehd.robot.controller import ACTION_MODES, ControlConfig, RobotController
from samplehd.robot.kinematics import fk_tcp, pos_quat_from_pose


def _rotation_angle(r: np.ndarray) -> float:
    return float(np.arccos(np.clip((np.trace(r) - 1) / 2, -1, 1)))


def test_config_defaults_and_validation() -> None:
    cfg = ControlConfig()
    assert cfg.substeps == 25 and cfg.control_dt == pytest.approx(0.05)
    bad = [
        dict(control_hz=30.0),  # 500 / 30 is not an integer
        dict(physics_hz=-1.0),
        dict(control_hz=float("nan")),
        dict(speed_scale=1.5),
        dict(safety_checks_per_step=4),  # does not divide 25
        dict(max_cartesian_delta=(0.05, -1.0)),
    ]
    for kwargs in bad:
        with pytest.raises(ConfigError) as err:
            ControlConfig(**kwargs)
        assert "\n" not in str(err.value)
    with pytest.raises(ConfigError, match="timestep"):
        RobotController(build_table_world().compile(), None, ControlConfig(physics_hz=1000.0))  # type: ignore[arg-type]


def test_bad_actions_raise_one_line_action_errors(controller: RobotController) -> None:
    cases = [
        (np.zeros(7), "fly"),
        (np.zeros(6), "joint_position"),
        (np.zeros(7), "cartesian_pose"),
        (np.r_[HOME_QPOS, np.nan], "joint_position"),
        (np.r_[np.inf, np.zeros(6)], "steering"),
        (np.r_[0.4, 0.0, 0.3, 0, 0, 0, 0, 1.0], "cartesian_pose"),  # zero quaternion
    ]
    for action, mode in cases:
        with pytest.raises(ActionError) as err:
            controller.step(action, mode)
        assert "\n" not in str(err.value)
    assert set(ACTION_MODES) == {"joint_position", "joint_delta", "cartesian_pose", "cartesian_delta", "steering"}


def test_out_of_range_values_are_clipped_and_reported(controller: RobotController) -> None:
    report = controller.step(np.r_[HOME_QPOS, 3.0], "joint_position")
    assert report.clipped == ("gripper",)
    assert controller.gripper_width == pytest.approx(GRIPPER_STROKE)
    report = controller.step(np.r_[5.0, 0, 0, 0, 0, 0, 1.0], "steering")
    assert "steering" in report.clipped
    report = controller.step(np.r_[HOME_QPOS[:2], 4.0, HOME_QPOS[3:], 1.0], "joint_position")
    assert "joint_limits" in report.clipped and controller.target[2] == pytest.approx(JOINT_LIMITS[2, 1])
    report = controller.step(np.r_[1.0, 0, 0, 0, 0, 0, 1.0], "joint_delta")
    assert "joint_delta" in report.clipped
    report = controller.step(np.r_[0.5, 0, 0, 0, 0, 0, 1.0], "cartesian_delta")
    assert "cartesian_delta" in report.clipped


def test_motion_is_continuous_and_within_speed_limits() -> None:
    model = build_table_world().compile()
    data = mujoco.MjData(model)
    cfg = ControlConfig()
    ctrl = RobotController(model, data, cfg)
    ctrl.reset(HOME_QPOS)
    target = HOME_QPOS + np.array([1.5, 0.4, -0.6, 0.8, 1.0, 2.0])
    ramps, qs = [], []
    for _ in range(30):
        ctrl.command(np.r_[target, 1.0], "joint_position")
        before = ctrl.interpolated_target
        ctrl.advance()
        ramps.append(ctrl.interpolated_target - before)
        qs.append(ctrl.joint_positions())
    ramps = np.array(ramps)
    # the target ramp never moves faster than the joint speed limits
    assert np.all(np.abs(ramps) <= SPEED_LIMITS * cfg.control_dt + 1e-9)
    # the slowest joint (wrist 3, 2 rad) sets the pace and all joints arrive together
    moving = np.abs(ramps).sum(axis=1) > 1e-12
    assert moving.sum() == int(np.ceil(2.0 / (np.pi * cfg.control_dt)))
    np.testing.assert_allclose(ctrl.interpolated_target, target, atol=1e-12)
    np.testing.assert_allclose(ctrl.joint_positions(), target, atol=1e-3)
    # measured joints move continuously: per control step never more than the speed limit allows
    dq = np.abs(np.diff(np.array(qs), axis=0))
    assert np.all(dq <= 1.2 * SPEED_LIMITS * cfg.control_dt)
    assert np.all(np.abs(ctrl.joint_velocities()) < 0.05)


def test_interpolation_inside_a_control_step_is_linear() -> None:
    model = build_table_world().compile()
    data = mujoco.MjData(model)
    ctrl = RobotController(model, data, ControlConfig(safety=None))
    ctrl.reset(HOME_QPOS)
    target = HOME_QPOS + 0.05
    ctrl.command(np.r_[target, 1.0], "joint_position")
    # one control period by hand, one physics step at a time, as advance() does in chunks
    ramp = target - ctrl.interpolated_target
    data.ctrl[:12] = np.r_[ramp, ramp] / ctrl.config.control_dt
    points = []
    for _ in range(ctrl.config.substeps):
        mujoco.mj_step(model, data)
        points.append(ctrl.interpolated_target)
    steps = np.diff(np.array([HOME_QPOS, *points]), axis=0)
    np.testing.assert_allclose(steps, np.tile(ramp / ctrl.config.substeps, (ctrl.config.substeps, 1)), atol=1e-12)


def test_joint_position_reaches_target_and_holds(controller: RobotController) -> None:
    target = HOME_QPOS + np.array([0.3, -0.2, 0.2, 0.1, -0.1, 0.5])
    for _ in range(20):
        controller.step(np.r_[target, 1.0], "joint_position")
    np.testing.assert_allclose(controller.joint_positions(), target, atol=2e-3)


def test_joint_delta_accumulates(controller: RobotController) -> None:
    for _ in range(10):
        controller.step(np.r_[0.05, 0, 0, 0, 0, -0.05, 1.0], "joint_delta")
    for _ in range(5):
        controller.step(np.r_[np.zeros(6), 1.0], "joint_delta")
    np.testing.assert_allclose(controller.target, HOME_QPOS + np.r_[0.5, 0, 0, 0, 0, -0.5], atol=1e-12)
    np.testing.assert_allclose(controller.joint_positions(), controller.target, atol=2e-3)


def test_cartesian_pose_reaches_target(controller: RobotController) -> None:
    goal = fk_tcp(HOME_QPOS)
    goal[:3, 3] += [0.05, 0.15, -0.2]
    pos, quat = pos_quat_from_pose(goal)
    for _ in range(30):
        report = controller.step(np.r_[pos, quat, 1.0], "cartesian_pose")
        assert not report.unreachable
    reached = fk_tcp(controller.joint_positions())
    np.testing.assert_allclose(reached[:3, 3], goal[:3, 3], atol=2e-3)
    assert _rotation_angle(reached[:3, :3].T @ goal[:3, :3]) < 5e-3


def test_unreachable_cartesian_pose_holds_and_reports(controller: RobotController) -> None:
    before = controller.target
    report = controller.step(np.r_[3.0, 0.0, 0.3, 1.0, 0, 0, 0, 1.0], "cartesian_pose")
    assert report.unreachable
    np.testing.assert_allclose(controller.target, before)
    strict = RobotController(controller.model, controller.data, ControlConfig(raise_unreachable=True))
    with pytest.raises(UnreachableError):
        strict.command(np.r_[3.0, 0.0, 0.3, 1.0, 0, 0, 0, 1.0], "cartesian_pose")


def test_steering_moves_the_tcp_at_the_scaled_speed_in_the_base_frame(controller: RobotController) -> None:
    cfg = controller.config
    start = fk_tcp(controller.joint_positions())
    for _ in range(20):  # 1 s
        controller.step(np.r_[1.0, 0, -0.5, 0, 0, 0, 1.0], "steering")
    for _ in range(5):
        controller.step(np.r_[np.zeros(6), 1.0], "steering")
    end = fk_tcp(controller.joint_positions())
    np.testing.assert_allclose(
        end[:3, 3] - start[:3, 3], [cfg.max_linear_speed, 0, -0.5 * cfg.max_linear_speed], atol=2e-3
    )
    assert _rotation_angle(start[:3, :3].T @ end[:3, :3]) < 5e-3
    # rotation about the base z axis at full speed for 0.5 s, about the TCP
    for _ in range(10):
        controller.step(np.r_[0, 0, 0, 0, 0, 1.0, 1.0], "steering")
    for _ in range(5):
        controller.step(np.r_[np.zeros(6), 1.0], "steering")
    turned = fk_tcp(controller.joint_positions())
    assert _rotation_angle(end[:3, :3].T @ turned[:3, :3]) == pytest.approx(0.5 * cfg.max_angular_speed, abs=5e-3)
    np.testing.assert_allclose(turned[:3, 3], end[:3, 3], atol=2e-3)


def test_cartesian_delta(controller: RobotController) -> None:
    start = fk_tcp(controller.joint_positions())
    for _ in range(4):
        controller.step(np.r_[0.0, 0.02, 0.01, 0, 0, 0, 1.0], "cartesian_delta")
    for _ in range(4):
        controller.step(np.r_[np.zeros(6), 1.0], "cartesian_delta")
    end = fk_tcp(controller.joint_positions())
    np.testing.assert_allclose(end[:3, 3] - start[:3, 3], [0.0, 0.08, 0.04], atol=2e-3)


def test_other_rates() -> None:
    model = build_table_world(timestep=0.001).compile()
    data = mujoco.MjData(model)
    ctrl = RobotController(model, data, ControlConfig(physics_hz=1000.0, control_hz=10.0))
    ctrl.reset(HOME_QPOS)
    report = ctrl.step(np.r_[HOME_QPOS + 0.1, 1.0], "joint_position")
    assert report.time == pytest.approx(0.1)
    np.testing.assert_allclose(ctrl.interpolated_target, HOME_QPOS + 0.1, atol=1e-12)


def test_joint_targets_within_the_limits_are_kept_as_given(controller: RobotController) -> None:
    """Targets on or inside the limits keep their bits and report nothing; one beyond is clipped."""
    on_limits = np.where(np.arange(6) % 2 == 0, JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1])
    inside = HOME_QPOS + np.nextafter(0.0, 1.0)
    for target in (on_limits, inside):
        report = controller.command(np.r_[target, 2.0], "joint_position")
        assert report.clipped == ("gripper",) and not report.unreachable
        assert np.array_equal(controller.target, target)
        assert controller.gripper_width == pytest.approx(GRIPPER_STROKE)
    beyond = on_limits.copy()
    beyond[3] = np.nextafter(JOINT_LIMITS[3, 1], np.inf)
    report = controller.command(np.r_[beyond, 0.0], "joint_position")
    assert report.clipped == ("joint_limits",)
    assert np.array_equal(controller.target, np.clip(beyond, JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1]))
