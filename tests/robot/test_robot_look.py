"""The robot's looks: the UR5e's real meshes and a Robotiq-like hand (``mesh``) or primitives (``primitive``),
with one physics."""

from __future__ import annotations

import itertools

import mujoco
import numpy as np
import pytest
from scipy.spatial import cKDTree

from samplehd.errors import ConfigError
from samplehd.render.renderer import SEG_ROBOT, SceneRenderer
from samplehd.robot.constants import (
    DH_D,
    GRIPPER_FINGER_JOINTS,
    GRIPPER_STROKE,
    HOME_QPOS,
    JOINT_NAMES,
    LINK_NAMES,
    ROBOT_BODY,
    ROBOT_LOOKS,
)
from samplehd.robot.controller import RobotController
from samplehd.robot.meshes import DATA_DIR, arm_meshes
from samplehd.robot.ur5e import robot_spec
from samplehd.scene.world import WorldConfig, compile_world

ARM_BODIES = (ROBOT_BODY, *LINK_NAMES)
HAND_BODIES = ("robot_gripper", "robot_left_finger", "robot_right_finger")
_MESH = mujoco.mjtGeom.mjGEOM_MESH


@pytest.fixture(scope="module")
def looks() -> dict[str, mujoco.MjModel]:
    return {look: robot_spec(look).compile() for look in ROBOT_LOOKS}


def _look_geoms(model: mujoco.MjModel) -> list[int]:
    """The geoms the mesh look adds: the arm's meshes and the hand's shapes."""
    return [g for g in range(model.ngeom) if model.geom_type[g] == _MESH or "_look_" in model.geom(g).name]


def _primitive_geoms(model: mujoco.MjModel) -> list[int]:
    look = set(_look_geoms(model))
    return [g for g in range(model.ngeom) if g not in look]


def test_looks_have_the_same_bodies_and_collision_geoms(looks: dict[str, mujoco.MjModel]) -> None:
    mesh, prim = looks["mesh"], looks["primitive"]
    for field in ("body_mass", "body_inertia", "body_ipos", "body_iquat", "body_pos", "body_quat",
                  "body_subtreemass", "jnt_pos", "jnt_axis", "dof_M0", "dof_armature", "dof_damping"):
        np.testing.assert_array_equal(getattr(mesh, field), getattr(prim, field), err_msg=field)
    same = _primitive_geoms(mesh)
    assert [mesh.geom(g).name for g in same] == [prim.geom(g).name for g in range(prim.ngeom)]
    for field in ("geom_type", "geom_size", "geom_pos", "geom_quat", "geom_contype", "geom_conaffinity",
                  "geom_friction", "geom_priority", "geom_solref", "geom_solimp", "geom_condim", "geom_margin"):
        np.testing.assert_array_equal(getattr(mesh, field)[same], getattr(prim, field), err_msg=field)


def test_meshes_are_drawn_only_and_primitives_hidden(looks: dict[str, mujoco.MjModel]) -> None:
    m = looks["mesh"]
    hand = [g for g in _look_geoms(m) if "_look_" in m.geom(g).name]
    meshes = [g for g in _look_geoms(m) if g not in hand]
    assert {m.body(int(m.geom_bodyid[g])).name for g in meshes} == set(ARM_BODIES)
    assert {m.body(int(m.geom_bodyid[g])).name for g in hand} == set(HAND_BODIES)
    # the hand is one mesh per body and material: a few draw calls, not a geom per shape
    assert all(m.geom_type[g] == _MESH for g in hand) and len(hand) <= 9
    for g in meshes + hand:
        assert m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0
        assert m.geom_group[g] == 1  # drawn by default, as the decorative geoms
        assert m.geom(g).name.startswith("robot_")
    robot = {m.body(b).id for b in ARM_BODIES + HAND_BODIES}
    for g, drawn in zip(_primitive_geoms(m), looks["primitive"].geom_group, strict=True):
        # the robot's primitives are hidden (group 3 is not drawn by default); the wrist camera's housing stays
        name = m.geom(g).name
        assert m.geom_group[g] == (3 if m.geom_bodyid[g] in robot and "camera" not in name else drawn), name
    arm_faces = sum(int(m.mesh_facenum[m.geom_dataid[g]]) for g in meshes)
    assert arm_faces == sum(len(p.faces) for ps in arm_meshes().parts.values() for p in ps)


def test_the_fingers_look_moves_with_the_finger_joints(looks: dict[str, mujoco.MjModel]) -> None:
    """Opening the gripper moves each finger's shapes by half the opening, outwards, and nothing else."""
    m = looks["mesh"]
    d = mujoco.MjData(m)
    fingers = {side: [g for g in _look_geoms(m) if m.geom(g).name.startswith(f"robot_{side}_finger_look")]
               for side in ("left", "right")}
    assert all(len(gs) >= 3 for gs in fingers.values())
    tips = []
    for opening in (0.0, GRIPPER_STROKE):
        for j in GRIPPER_FINGER_JOINTS:
            d.qpos[m.joint(j).qposadr[0]] = opening / 2
        mujoco.mj_kinematics(m, d)
        tips.append(d.geom_xpos.copy())
    gripper = m.body("robot_gripper").id
    out = d.xmat[gripper].reshape(3, 3)[:, 1]  # the right finger opens along the gripper's +y
    for side, sign in (("left", -1.0), ("right", 1.0)):
        for g in fingers[side]:
            np.testing.assert_allclose(tips[1][g] - tips[0][g], sign * GRIPPER_STROKE / 2 * out, atol=1e-9)
    still = [g for g in _look_geoms(m) if m.geom_bodyid[g] == gripper]
    np.testing.assert_array_equal(tips[1][still], tips[0][still])


def test_same_motion_bit_for_bit() -> None:
    """Driving both looks with the same commands gives the same states, bit for bit."""
    runs = []
    for look in ROBOT_LOOKS:
        model, data = compile_world(config=WorldConfig(robot_look=look))
        ctrl = RobotController(model, data)
        ctrl.reset(HOME_QPOS)
        for k in range(20):
            ctrl.step(np.r_[HOME_QPOS + 0.3 * np.sin(k / 4.0), 1.0 - 0.1 * k], "joint_position")
        runs.append((data.qpos.copy(), data.qvel.copy(), data.act.copy()))
    for a, b in zip(*runs, strict=True):
        np.testing.assert_array_equal(a, b)


def test_adjacent_link_meshes_meet_at_their_joints(looks: dict[str, mujoco.MjModel]) -> None:
    """A link placed wrongly (offset, or turned about anything but its joint axis) leaves a gap to its
    neighbour at most joint angles; the vendored meshes meet within 3 mm everywhere."""
    m = looks["mesh"]
    d = mujoco.MjData(m)
    verts = {b: np.concatenate([p.vertices for p in arm_meshes().parts[b]]).astype(float) for b in ARM_BODIES}
    qadr = [m.joint(j).qposadr[0] for j in JOINT_NAMES]
    rng = np.random.default_rng(7)
    for _ in range(8):
        d.qpos[qadr] = rng.uniform(-np.pi, np.pi, len(qadr))
        mujoco.mj_kinematics(m, d)
        world = {b: verts[b] @ d.xmat[m.body(b).id].reshape(3, 3).T + d.xpos[m.body(b).id] for b in ARM_BODIES}
        for parent, child in itertools.pairwise(ARM_BODIES):
            gap = float(cKDTree(world[parent]).query(world[child])[0].min())
            assert gap < 0.003, (parent, child, gap)
    # the tool flange of the wrist-3 mesh is the DH flange, where the gripper sits
    assert verts["robot_wrist_3_link"][:, 2].max() == pytest.approx(DH_D[5], abs=1e-3)


def test_vendored_files_licensed_and_small() -> None:
    names = {p.name for p in DATA_DIR.iterdir()}
    assert {"LICENSE", "LICENSE.robosuite", "files.md", "look.json"} <= names
    assert (DATA_DIR / "LICENSE.robosuite").read_text().startswith("MIT License")
    assert "Redistribution and use in source and binary forms" in (DATA_DIR / "LICENSE").read_text()
    provenance = (DATA_DIR / "files.md").read_text()
    for body in ARM_BODIES:
        assert f"{body.removeprefix('robot_')}.npz" in provenance
    assert sum(p.stat().st_size for p in DATA_DIR.iterdir()) < 3_000_000


def test_unknown_look_is_refused() -> None:
    with pytest.raises(ConfigError, match="primitive"):
        robot_spec("cartoon")
    with pytest.raises(ConfigError, match="robot_look"):
        WorldConfig(robot_look="cartoon")


@pytest.mark.render
def test_segmentation_labels_the_meshes_as_robot() -> None:
    """The robot's segmentation follows what is drawn: the meshes are robot pixels, about as many as the
    primitives give."""
    pixels = {}
    for look in ROBOT_LOOKS:
        model, data = compile_world(config=WorldConfig(robot_look=look))
        with SceneRenderer(model, 160, 90, "fast") as r:
            seg = r.render(data, "operator", ("segmentation",))["segmentation"]
        pixels[look] = int((seg == SEG_ROBOT).sum())
    assert pixels["primitive"] > 150
    assert 0.6 < pixels["mesh"] / pixels["primitive"] < 1.6, pixels


@pytest.mark.parametrize("look", ROBOT_LOOKS)
def test_worlds_get_the_same_robot_from_the_kept_spec(look):
    """Worlds attach a copy of one robot spec per look; the model is byte for byte the one a freshly built
    robot spec gives, however many worlds came before."""
    from samplehd.robot import ur5e

    def model_bytes() -> bytes:
        model = compile_world([], WorldConfig(robot_look=look))[0]
        buf = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
        mujoco.mj_saveModel(model, None, buf)
        return buf.tobytes()

    ur5e._KEPT.specs = {}
    fresh = model_bytes()
    assert model_bytes() == fresh and model_bytes() == fresh
    assert ur5e._KEPT.specs[look] is not None
