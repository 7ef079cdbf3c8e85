"""The procedural UR5e + gripper model: names, structure, masses, contacts, gripper strength."""

from __future__ import annotations

import os
import warnings

import mujoco
import numpy as np
import pytest
from robot_world import add_box, build_table_world

from samplehd.robot.constants import (
    GRIPPER_ACTUATOR,
    GRIPPER_FINGER_JOINTS,
    GRIPPER_STROKE,
    HOME_QPOS,
    JOINT_LIMITS,
    JOINT_NAMES,
    LINK_MASSES,
    LINK_NAMES,
    POSITION_ACTUATORS,
    ROBOT_BODY,
    TCP_OFFSET,
    TORQUE_LIMITS,
    VELOCITY_ACTUATORS,
)
from samplehd.robot.controller import RobotController
from samplehd.robot.kinematics import fk_tcp, pose_from_pos_quat
from samplehd.robot.ur5e import add_robot, robot_spec


def _robot_bodies(model: mujoco.MjModel) -> set[int]:
    root = model.body(ROBOT_BODY).id
    out = {root}
    for b in range(root + 1, model.nbody):
        if model.body_parentid[b] in out:
            out.add(b)
    return out


def test_contract_names_and_actuator_order(table_model: mujoco.MjModel) -> None:
    m = table_model
    for j in JOINT_NAMES:
        assert m.joint(j).type == mujoco.mjtJoint.mjJNT_HINGE
    for site in ("flange", "tcp"):
        assert m.site(site).id >= 0
    assert m.camera("wrist").id >= 0
    names = [m.actuator(i).name for i in range(m.nu)]
    assert names == [*POSITION_ACTUATORS, *VELOCITY_ACTUATORS, GRIPPER_ACTUATOR]
    robot = _robot_bodies(m)
    for b in robot:
        assert m.body(b).name.startswith("robot_")
    for g in range(m.ngeom):
        if m.geom_bodyid[g] in robot:
            assert m.geom(g).name.startswith("robot_")
    # every joint, site and camera of the robot hangs below robot_base
    for j in [*JOINT_NAMES, *GRIPPER_FINGER_JOINTS]:
        assert m.jnt_bodyid[m.joint(j).id] in robot
    assert m.site_bodyid[m.site("tcp").id] in robot and m.cam_bodyid[m.camera("wrist").id] in robot


def test_limits_are_radians_and_torques_bounded(table_model: mujoco.MjModel) -> None:
    m = table_model
    for i, j in enumerate(JOINT_NAMES):
        jid = m.joint(j).id
        np.testing.assert_allclose(m.jnt_range[jid], JOINT_LIMITS[i])
        np.testing.assert_allclose(m.jnt_actfrcrange[jid], [-TORQUE_LIMITS[i], TORQUE_LIMITS[i]])
    gripper = m.actuator(GRIPPER_ACTUATOR).id
    np.testing.assert_allclose(m.actuator_ctrlrange[gripper], [0.0, GRIPPER_STROKE])
    for j in GRIPPER_FINGER_JOINTS:
        np.testing.assert_allclose(m.jnt_range[m.joint(j).id], [0.0, GRIPPER_STROKE / 2])


def test_link_masses_are_realistic(table_model: mujoco.MjModel) -> None:
    m = table_model
    masses = [m.body_mass[m.body(n).id] for n in (ROBOT_BODY, *LINK_NAMES)]
    np.testing.assert_allclose(masses, LINK_MASSES, rtol=1e-6)
    gripper = sum(m.body_mass[m.body(n).id] for n in ("robot_gripper", "robot_left_finger", "robot_right_finger"))
    assert 0.7 < gripper < 1.2
    assert np.all(m.body_inertia[list(_robot_bodies(m))] > 0)


def test_no_contacts_at_home_and_zero(table_model: mujoco.MjModel) -> None:
    data = mujoco.MjData(table_model)
    qadr = [table_model.jnt_qposadr[table_model.joint(j).id] for j in JOINT_NAMES]
    for q in (HOME_QPOS, np.array([0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0])):
        data.qpos[qadr] = q
        mujoco.mj_forward(table_model, data)
        assert data.ncon == 0, [(table_model.geom(c.geom1).name, table_model.geom(c.geom2).name) for c in data.contact]


def test_tcp_between_fingertips_and_home_points_down(table_model: mujoco.MjModel) -> None:
    data = mujoco.MjData(table_model)
    RobotController(table_model, data).reset(HOME_QPOS)
    pads = [data.geom(f"robot_{s}_finger_pad").xpos for s in ("left", "right")]
    np.testing.assert_allclose(data.site("tcp").xpos, (pads[0] + pads[1]) / 2, atol=1e-9)
    np.testing.assert_allclose(data.site("tcp").xmat.reshape(3, 3)[:, 2], [0, 0, -1], atol=1e-3)
    assert data.site("tcp").xpos[2] > 0.75 + 0.3
    tcp = fk_tcp(HOME_QPOS)
    assert tcp[0, 3] > 0.3  # reaches over the table (+x)
    # the wrist camera looks along the approach direction (camera frame looks along its -z)
    view = -data.cam_xmat[table_model.camera("wrist").id].reshape(3, 3)[:, 2]
    assert view @ data.site("tcp").xmat.reshape(3, 3)[:, 2] > 0.9  # tilted 20° towards the fingertips
    # the pads are the lowest part of each finger (thin objects can be pinched)
    for side in ("left", "right"):
        pad = data.geom(f"robot_{side}_finger_pad")
        bar = data.geom(f"robot_{side}_finger_bar")
        lowest = [g.xpos[2] - np.abs(g.xmat.reshape(3, 3)[2]) @ table_model.geom_size[g.id] for g in (pad, bar)]
        assert lowest[0] <= lowest[1] + 1e-6
    assert TCP_OFFSET == pytest.approx(np.linalg.norm(data.site("tcp").xpos - data.site("flange").xpos))


def test_attach_into_rotated_frame_and_roundtrip_xml(tmp_path) -> None:
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            spec = mujoco.MjSpec()
            body = spec.worldbody.add_body(name="stand", pos=[1.0, 2.0, 0.5])
            root = add_robot(body, (0.1, 0.0, 0.2), (0.0, 0.0, 0.0, 1.0), spec=spec)
            assert root.name == ROBOT_BODY
            model = spec.compile()
            xml = spec.to_xml()
        assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    finally:
        os.chdir(cwd)
    reloaded = mujoco.MjModel.from_xml_string(xml, spec.assets)  # the arm's meshes are in-memory files
    assert reloaded.nu == model.nu == 13 and reloaded.nbody == model.nbody
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    base = pose_from_pos_quat(np.array([1.1, 2.0, 0.7]), np.array([0.0, 0.0, 0.0, 1.0]))
    np.testing.assert_allclose(data.site("tcp").xpos, (base @ fk_tcp(np.zeros(6)))[:3, 3], atol=1e-9)
    assert robot_spec().compile().nu == 13


def test_gripper_opens_closes_symmetrically(controller: RobotController) -> None:
    d = controller.data
    left, right = (controller.model.joint(j).qposadr[0] for j in GRIPPER_FINGER_JOINTS)
    for _ in range(10):
        controller.step(np.r_[HOME_QPOS, 1.0], "joint_position")
    assert d.qpos[left] + d.qpos[right] == pytest.approx(GRIPPER_STROKE, abs=1e-3)
    for _ in range(15):
        controller.step(np.r_[HOME_QPOS, -1.0], "joint_position")
    assert d.qpos[left] + d.qpos[right] == pytest.approx(0.0, abs=1e-3)
    assert d.qpos[left] == pytest.approx(d.qpos[right], abs=1e-4)


def _grasp_box(mass: float = 0.3) -> tuple[RobotController, int]:
    above = fk_tcp(HOME_QPOS)[:3, 3]
    spec = build_table_world(lambda s: add_box(s, 0, [above[0] - 0.40, 0.0, 0.75 + 0.04], mass=mass))
    model = spec.compile()
    data = mujoco.MjData(model)
    ctrl = RobotController(model, data)
    ctrl.reset(HOME_QPOS)
    down = np.r_[above[:2], 0.06, 0.0, 1.0, 0.0, 0.0]  # TCP 6 cm above the base plane, pointing down
    for gripper, steps in ((1.0, 25), (-1.0, 15)):
        for _ in range(steps):
            report = ctrl.step(np.r_[down, gripper], "cartesian_pose")
            assert report.safety_event is None
    return ctrl, model.body("object_0").id


def test_gripper_holds_300g_against_gravity_and_fast_moves() -> None:
    ctrl, obj = _grasp_box(0.3)
    d = ctrl.data
    lift = np.r_[fk_tcp(HOME_QPOS)[:3, 3], 0.0, 1.0, 0.0, 0.0]
    for _ in range(20):
        ctrl.step(np.r_[lift, -1.0], "cartesian_pose")
    grasp_offset = d.xpos[obj] - d.site("tcp").xpos
    assert d.xpos[obj][2] > 0.75 + 0.25  # lifted 25 cm
    # fast moves: full-speed steering back and forth, then a full-speed pan swing
    for _ in range(2):
        for sign in (1.0, -1.0):
            for _ in range(10):
                report = ctrl.step(np.r_[sign, sign, 0.5 * sign, 0.0, 0.0, sign, -1.0], "steering")
                assert report.safety_event is None
    q = ctrl.joint_positions()
    for target in (q + [1.0, 0, 0, 0, 0, 0], q):
        for _ in range(12):
            ctrl.step(np.r_[target, -1.0], "joint_position")
    drift = np.linalg.norm(d.xpos[obj] - d.site("tcp").xpos - grasp_offset)
    assert drift < 0.015, f"object slipped {drift * 1000:.1f} mm in the grasp"
    assert np.linalg.norm(d.xpos[obj] - d.site("tcp").xpos) < 0.05
