"""Safety monitor: every event forced for real, the arm holds, commands are ignored until reset."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from robot_world import add_box, build_table_world

from samplehd.errors import ConfigError
from samplehd.robot.constants import HOME_QPOS
from samplehd.robot.controller import ControlConfig, RobotController
from samplehd.robot.kinematics import fk_tcp
from samplehd.robot.safety import SAFETY_EVENT_CODES, SafetyConfig, SafetyEvent

DOWN = np.array([0.0, 1.0, 0.0, 0.0])  # TCP pointing down (rotation of pi about x), w x y z


def _controller(model: mujoco.MjModel, safety: SafetyConfig | None = None) -> RobotController:
    data = mujoco.MjData(model)
    ctrl = RobotController(model, data, ControlConfig(safety=safety or SafetyConfig()))
    ctrl.reset(HOME_QPOS)
    return ctrl


def _run_until_event(ctrl: RobotController, action: np.ndarray, mode: str, steps: int = 60) -> SafetyEvent:
    for _ in range(steps):
        report = ctrl.step(action, mode)
        if report.safety_event is not None:
            return report.safety_event
    raise AssertionError("no safety event")


def _assert_holds_and_ignores(ctrl: RobotController, event: SafetyEvent) -> None:
    assert ctrl.stopped == event
    held = ctrl.joint_positions()
    for _ in range(10):
        report = ctrl.step(np.r_[HOME_QPOS, 1.0], "joint_position")
        assert report.ignored and report.safety_event is None
    np.testing.assert_allclose(ctrl.joint_positions(), held, atol=0.02)
    assert np.all(np.abs(ctrl.joint_velocities()) < 0.05)
    # after a reset the arm obeys again
    ctrl.reset(HOME_QPOS)
    assert ctrl.stopped is None
    report = ctrl.step(np.r_[HOME_QPOS, 1.0], "joint_position")
    assert not report.ignored and report.safety_event is None


def test_driving_into_the_table_stops_the_arm(table_model: mujoco.MjModel) -> None:
    ctrl = _controller(table_model)
    xy = fk_tcp(HOME_QPOS)[:2, 3]
    event = _run_until_event(ctrl, np.r_[xy, -0.10, DOWN, 1.0], "cartesian_pose")
    assert event.kind == "environment_collision"
    assert event.bodies[0].startswith("robot_") and event.bodies[1] == "table"
    assert event.geoms[1] == "table_top"
    assert 0.0 < event.time < 3.0 and event.time == pytest.approx(ctrl.data.time, abs=0.05)
    _assert_holds_and_ignores(ctrl, event)


def test_folding_into_itself_stops_the_arm(table_model: mujoco.MjModel) -> None:
    ctrl = _controller(table_model)
    target = HOME_QPOS + np.array([0.0, 0.0, 1.5, 0.0, 0.0, 0.0])  # elbow folds the gripper onto the base
    event = _run_until_event(ctrl, np.r_[target, 1.0], "joint_position")
    assert event.kind == "self_collision"
    assert all(b.startswith("robot_") for b in event.bodies) and event.bodies[0] != event.bodies[1]
    _assert_holds_and_ignores(ctrl, event)


def test_reaching_into_the_wall_stops_the_arm(table_model: mujoco.MjModel) -> None:
    ctrl = _controller(table_model)
    target = np.array([0.0, -0.4, 0.0, -np.pi / 2, 0.0, 0.0])  # arm stretched out, slightly raised
    target[0] = HOME_QPOS[0] - np.pi
    event = _run_until_event(ctrl, np.r_[target, 1.0], "joint_position", steps=80)
    assert event.kind == "environment_collision" and event.bodies[1] == "world"
    assert event.geoms[1] == "backdrop_wall"


def _fixed_block_world() -> mujoco.MjModel:
    xy = fk_tcp(HOME_QPOS)[:2, 3] + np.array([-0.40, 0.0])
    return build_table_world(
        lambda s: add_box(s, 0, [xy[0], xy[1], 0.85], half=(0.05, 0.05, 0.10), free=False)
    ).compile()


def test_pushing_an_object_too_hard_stops_the_arm() -> None:
    ctrl = _controller(_fixed_block_world())
    xy = fk_tcp(HOME_QPOS)[:2, 3]
    event = _run_until_event(ctrl, np.r_[xy, 0.0, DOWN, -1.0], "cartesian_pose")
    assert event.kind == "contact_force"
    assert event.bodies[0].startswith("robot_") and event.bodies[1] == "object_0"
    assert event.value > event.threshold == ctrl.config.safety.max_contact_force
    _assert_holds_and_ignores(ctrl, event)


def test_sustained_joint_overload_stops_the_arm() -> None:
    safety = SafetyConfig(max_contact_force=1e9, torque_hold_time=0.1)
    ctrl = _controller(_fixed_block_world(), safety)
    xy = fk_tcp(HOME_QPOS)[:2, 3]
    event = _run_until_event(ctrl, np.r_[xy, 0.0, DOWN, -1.0], "cartesian_pose", steps=100)
    assert event.kind == "joint_torque"
    assert event.joint.endswith("_joint") and event.value >= event.threshold
    _assert_holds_and_ignores(ctrl, event)


def test_touching_objects_is_allowed() -> None:
    # a light free box: the open gripper comes down around it and closes; no event
    xy = fk_tcp(HOME_QPOS)[:2, 3]
    spec = build_table_world(lambda s: add_box(s, 0, [xy[0] - 0.40, xy[1], 0.79]))
    ctrl = _controller(spec.compile())
    for gripper, steps in ((1.0, 25), (-1.0, 10)):
        for _ in range(steps):
            report = ctrl.step(np.r_[xy, 0.06, DOWN, gripper], "cartesian_pose")
            assert report.safety_event is None


def test_event_record() -> None:
    event = SafetyEvent("contact_force", 1.25, ("robot_left_finger", "object_2"), ("a", "b"), "", 200.0, 150.0)
    assert SafetyEvent.from_dict(event.to_dict()) == event
    assert "\n" not in str(event) and "object_2" in str(event)
    assert event.code == SAFETY_EVENT_CODES["contact_force"] > 0
    with pytest.raises(ConfigError):
        SafetyConfig(torque_ratio=0.0)
    with pytest.raises(ConfigError):
        SafetyConfig(max_contact_force=-1.0)
    with pytest.raises(ConfigError, match="force_hold_time"):
        SafetyConfig(force_hold_time=-0.01)


def test_kitchen_world_home_is_safe_and_the_table_is_recognised(world) -> None:
    model, _ = world
    data = mujoco.MjData(model)
    ctrl = RobotController(model, data)
    ctrl.reset(HOME_QPOS)
    for _ in range(5):
        assert ctrl.step(np.r_[HOME_QPOS, 1.0], "joint_position").safety_event is None
    xy = fk_tcp(HOME_QPOS)[:2, 3]
    event = _run_until_event(ctrl, np.r_[xy, -0.10, DOWN, 1.0], "cartesian_pose")
    assert event.kind == "environment_collision" and event.bodies[1] == "table"
