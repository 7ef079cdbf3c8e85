"""Procedural UR5e arm with a parallel-jaw gripper, built with :class:`mujoco.MjSpec`.

The kinematic chain is the published DH chain of the UR5e: body ``robot_<link>`` i carries joint i
(a hinge about its local z axis), and its child sits at ``Tz(d_i) Tx(a_i) Rx(alpha_i)``; so the
site ``flange`` is exactly DH frame 6 and forward kinematics equal :mod:`samplehd.robot.kinematics`.

Names (relied upon by other packages, see docs/ARCHITECTURE.md):

- root body ``robot_base``; every robot body descends from it and is named ``robot_*``;
  every robot geom is named ``robot_*``;
- joints ``shoulder_pan_joint`` … ``wrist_3_joint``, finger slides ``robot_left_finger_joint`` and
  ``robot_right_finger_joint`` (kept equal by an equality constraint);
- sites ``flange`` (DH frame 6) and ``tcp`` (between the finger pads, z = approach direction);
- camera ``wrist`` on the gripper, looking along the approach direction.

Looks (:data:`~samplehd.robot.constants.ROBOT_LOOKS`): ``mesh`` (default) draws the arm with the UR5e's
real visual meshes (:mod:`samplehd.robot.meshes`) and the gripper as a Robotiq 2F-85-like hand made of
boxes and cylinders (:mod:`samplehd.robot.solids`, one mesh per body and material), and hides the
primitive geoms they replace in group 3, as the catalogue hides its collision geoms; ``primitive`` draws
the primitives. The look's geoms are massless and never collide, and the
primitives stay in the model unchanged (they collide, and their densities give the link masses), so both
looks have the same physics bit for bit; only what is drawn differs.

Actuators (``data.ctrl`` layout, in this order):

- ``robot_<joint>_position`` (6): integrated-velocity position servos. ``ctrl`` is the velocity of
  the joint's position target [rad/s]; MuJoCo integrates it into the target (``data.act``), so a
  target that ramps linearly needs no per-physics-step Python. Clamped to the speed limits.
- ``robot_<joint>_velocity`` (6): velocity servos fed the same ``ctrl`` (feed-forward, so a ramping
  target is tracked without lag). The sum of both servos and the gravity compensation of the arm is
  clamped to the UR5e torque limits per joint.
- ``robot_gripper``: finger opening width [m], 0 (closed) … 0.085 (open); the squeeze force is
  limited to :data:`~samplehd.robot.constants.GRIPPER_FORCE` per finger.

Use :class:`samplehd.robot.controller.RobotController` rather than writing ``ctrl`` directly.
"""

from __future__ import annotations

import math
import threading
import warnings
from collections.abc import Sequence

import mujoco
import numpy as np

from samplehd.errors import ConfigError
from samplehd.fixedmath import norm
from samplehd.physics import msh_file
from samplehd.robot.constants import (
    ARM_KP,
    ARM_KV,
    DH_A,
    DH_ALPHA,
    DH_D,
    GRIPPER_ACTUATOR,
    GRIPPER_FINGER_JOINTS,
    GRIPPER_FORCE,
    GRIPPER_STROKE,
    JOINT_ARMATURE,
    JOINT_DAMPING,
    JOINT_LIMITS,
    JOINT_NAMES,
    LINK_MASSES,
    LINK_NAMES,
    POSITION_ACTUATORS,
    ROBOT_BASE_QUAT,
    ROBOT_BODY,
    ROBOT_LOOKS,
    ROBOTIQ_BLACK_RGBA,
    ROBOTIQ_GREY_RGBA,
    ROBOTIQ_PAD_RGBA,
    ROBOTIQ_SILVER_RGBA,
    SPEED_LIMITS,
    TCP_OFFSET,
    TORQUE_LIMITS,
    UR_CAP_RGBA,
    UR_DARK_RGBA,
    UR_GREY_RGBA,
    UR_RING_RGBA,
    VELOCITY_ACTUATORS,
    WRIST_CAMERA,
)
from samplehd.robot.meshes import arm_meshes
from samplehd.robot.solids import SolidMesh

__all__ = ["add_robot", "robot_spec"]

# The robot is built in its own MjSpec and attached without a name prefix, so the names in
# docs/ARCHITECTURE.md hold in the world. MuJoCo warns that prefix-less attachment "may prevent the
# model from being saved correctly" at every later compile; the names are unique (robot_* or the UR
# joint names), so saving works and the warning is noise. add_robot installs this filter on each
# call, because test runners reset warning filters between tests.
_EMPTY_PREFIX_WARNING = "Attaching a spec with an empty prefix"

_GEOM = mujoco.mjtGeom
# Collision geoms are in group 0 (visible by default); decorative geoms that never collide
# (caps, rings, the camera housing) are in group 1.
_COLLISION_GROUP = 0
_VISUAL_GROUP = 1
# The mesh look draws the arm's meshes in the decorative group and moves the arm's primitives to group 3,
# which MuJoCo (and samplehd's renderers) do not draw by default.
_HIDDEN_GROUP = 3

# Finger geometry [m]: finger bodies hang below the gripper housing; pads face each other.
_HOUSING_BOTTOM = 0.087  # housing spans flange z 0.012 … 0.087
_PAD_CENTRE = TCP_OFFSET - _HOUSING_BOTTOM  # pad centre below the housing, so the TCP is between pads
_PAD_HALF = (0.011, 0.004, 0.0175)
# The bar ends where the pad ends, so the pads are the lowest part of the fingers and a top-down
# grasp can pinch thin objects (cutlery) a few millimetres above the table.
_BAR_HALF = (0.012, 0.006, (_PAD_CENTRE + _PAD_HALF[2]) / 2)
_FINGER_MASS = 0.05
_GRIPPER_HOUSING_MASS = 0.7
_COUPLING_MASS = 0.1
_PAD_FRICTION = (1.5, 0.02, 0.002)
# Finger servo: stiff enough that a 1 cm squeeze already saturates at the grip force, so thin
# objects are held as firmly as thick ones. Finger damping [N·s/m]: much more makes the squeezed
# pads oscillate against the finger-symmetry constraint and lets objects creep out of the grasp.
_GRIPPER_KP = 10000.0
_FINGER_DAMPING = 150.0


def _material(spec: mujoco.MjSpec, name: str, rgba: np.ndarray, specular: float, shininess: float) -> str:
    mat = spec.add_material(name=name)
    mat.rgba = rgba
    mat.specular = specular
    mat.shininess = shininess
    return name


class _LinkBuilder:
    """Adds geoms to one body and sets their densities so the body has a given mass."""

    def __init__(self, body: mujoco.MjsBody, name: str) -> None:
        self.body = body
        self.name = name
        self.geoms: list[tuple[mujoco.MjsGeom, float]] = []

    def cylinder(
        self,
        part: str,
        radius: float,
        z0: float,
        z1: float,
        material: str,
        *,
        axis: str = "z",
        at: Sequence[float] = (0.0, 0.0),
        collide: bool = True,
    ) -> mujoco.MjsGeom:
        """Cylinder along a body axis from coordinate z0 to z1, centred at ``at`` across it."""
        a, b = at
        if axis == "z":
            start, end = (a, b, z0), (a, b, z1)
        elif axis == "y":
            start, end = (a, z0, b), (a, z1, b)
        else:
            start, end = (z0, a, b), (z1, a, b)
        return self._add(part, _GEOM.mjGEOM_CYLINDER, [radius, 0, 0], material, collide, fromto=[*start, *end])

    def tube(self, part: str, radius: float, start: Sequence[float], end: Sequence[float], material: str):
        """Collision cylinder between two points of the body frame."""
        return self._add(part, _GEOM.mjGEOM_CYLINDER, [radius, 0, 0], material, True, fromto=[*start, *end])

    def box(
        self, part: str, half: Sequence[float], centre: Sequence[float], material: str, *, collide: bool = True
    ) -> mujoco.MjsGeom:
        return self._add(part, _GEOM.mjGEOM_BOX, list(half), material, collide, pos=list(centre))

    def _add(self, part, gtype, size, material, collide, **kw) -> mujoco.MjsGeom:
        geom = self.body.add_geom(name=f"{self.name}_{part}", type=gtype, size=size, material=material, **kw)
        geom.contype = 1 if collide else 0
        geom.conaffinity = 1 if collide else 0
        geom.group = _COLLISION_GROUP if collide else _VISUAL_GROUP
        self.geoms.append((geom, _volume(gtype, size, kw.get("fromto"))))
        return geom

    def set_mass(self, mass: float) -> None:
        """Give all geoms one density so that the body's mass is ``mass`` [kg]."""
        total = sum(v for _, v in self.geoms)
        for geom, _ in self.geoms:
            geom.density = mass / total


def _volume(gtype: int, size: Sequence[float], fromto: Sequence[float] | None) -> float:
    if gtype == _GEOM.mjGEOM_BOX:
        return 8.0 * size[0] * size[1] * size[2]
    assert fromto is not None  # cylinders are always given by fromto here
    length = float(norm(np.subtract(fromto[3:], fromto[:3])))
    return math.pi * size[0] ** 2 * length


def _quat_rx(angle: float) -> list[float]:
    return [math.cos(angle / 2), math.sin(angle / 2), 0.0, 0.0]


def _quat_ry(angle: float) -> list[float]:
    return [math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0]


def _add_arm_geometry(links: list[_LinkBuilder], grey: str, cap: str, ring: str, dark: str) -> None:
    """UR-like shapes: cylindrical joint housings with blue-grey caps and light-grey tubes.

    Each housing is a cylinder about its joint axis, so it is drawn on whichever side of the joint
    it belongs to; offsets along the joint axes follow the real arm (shoulder 0.138 m, elbow
    -0.131 m, wrist 0.127 m), which add up to d4.
    """
    base, shoulder, upper, fore, w1, w2, w3 = links
    base.cylinder("foot", 0.09, 0.0, 0.008, dark)
    base.cylinder("housing", 0.075, 0.008, 0.06, grey)
    base.cylinder("ring", 0.063, 0.06, 0.075, ring, collide=False)
    # Shoulder: vertical J1 housing rising into the horizontal J2 housing.
    shoulder.cylinder("housing", 0.06, 0.075, DH_D[0], grey)
    # Upper arm: J2 housing (cap facing away from the arm), tube, elbow housing.
    upper.cylinder("shoulder_housing", 0.06, -0.06, 0.185, grey)
    upper.cylinder("shoulder_cap", 0.057, -0.07, -0.06, cap, collide=False)
    upper.cylinder("shoulder_ring", 0.057, 0.185, 0.19, ring, collide=False)
    upper.tube("tube", 0.045, (0.0, 0.0, 0.138), (DH_A[1], 0.0, 0.138), grey)
    upper.cylinder("elbow_housing", 0.05, 0.07, 0.185, grey, at=(DH_A[1], 0.0))
    upper.cylinder("elbow_cap", 0.047, 0.185, 0.193, cap, at=(DH_A[1], 0.0), collide=False)
    # Forearm: rest of the elbow housing, tube, wrist-1 housing.
    fore.cylinder("elbow_housing", 0.05, -0.05, 0.07, grey)
    fore.cylinder("elbow_cap", 0.047, -0.058, -0.05, cap, collide=False)
    fore.tube("tube", 0.038, (0.0, 0.0, 0.007), (DH_A[2], 0.0, 0.007), grey)
    fore.cylinder("wrist_housing", 0.045, -0.045, 0.05, grey, at=(DH_A[2], 0.0))
    fore.cylinder("wrist_cap", 0.042, -0.052, -0.045, cap, at=(DH_A[2], 0.0), collide=False)
    # Wrists: each a housing about its own axis, capped on the outer side.
    w1.cylinder("housing", 0.045, 0.05, DH_D[3], grey)
    w2.cylinder("housing", 0.045, -0.05, 0.055, grey)
    w2.cylinder("cap", 0.042, -0.057, -0.05, cap, collide=False)
    w3.cylinder("housing", 0.045, -0.05, 0.085, grey)
    w3.cylinder("cap", 0.042, -0.057, -0.05, cap, collide=False)
    w3.cylinder("flange", 0.0315, 0.085, DH_D[5], ring)


def _add_gripper(spec: mujoco.MjSpec, wrist_3: mujoco.MjsBody, dark: str, metal: str, rubber: str,
                 look: str) -> None:
    gripper = wrist_3.add_body(name="robot_gripper", pos=[0.0, 0.0, DH_D[5]])
    gripper.gravcomp = 1.0
    g = _LinkBuilder(gripper, "robot_gripper")
    g.cylinder("coupling", 0.038, 0.0, 0.012, dark)
    g.box("housing", (0.035, 0.068, 0.0375), (0.0, 0.0, 0.0495), dark)
    g.box("rail", (0.014, 0.062, 0.004), (0.0, 0.0, _HOUSING_BOTTOM - 0.002), metal, collide=False)
    g.box("camera_housing", (0.012, 0.018, 0.012), (0.047, 0.0, 0.072), dark, collide=False)
    g.set_mass(_GRIPPER_HOUSING_MASS + _COUPLING_MASS)
    gripper.add_site(name="tcp", pos=[0.0, 0.0, TCP_OFFSET], size=[0.005, 0, 0], rgba=[1, 0.3, 0.1, 0.0])

    # Wrist camera beside the housing, looking along the approach (+z) direction, tilted 12° towards
    # the fingertips so they are in view; image up points away from the gripper (+x).
    tilt = math.radians(20.0)
    x_cam = np.array([0.0, 1.0, 0.0])
    z_cam = np.array([math.sin(tilt), 0.0, -math.cos(tilt)])
    y_cam = np.cross(z_cam, x_cam)
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.column_stack([x_cam, y_cam, z_cam]).reshape(9))
    gripper.add_camera(name=WRIST_CAMERA, pos=[0.06, 0.0, 0.08], quat=quat, fovy=75.0)

    builders, fingers = [g], []
    for side, sign, joint_name in (("left", -1.0, GRIPPER_FINGER_JOINTS[0]), ("right", 1.0, GRIPPER_FINGER_JOINTS[1])):
        finger = gripper.add_body(name=f"robot_{side}_finger", pos=[0.0, 0.0, _HOUSING_BOTTOM])
        finger.gravcomp = 1.0
        joint = finger.add_joint(
            name=joint_name,
            type=mujoco.mjtJoint.mjJNT_SLIDE,
            axis=[0.0, sign, 0.0],
            range=[0.0, GRIPPER_STROKE / 2],
            damping=_FINGER_DAMPING,
            armature=0.01,
        )
        joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        f = _LinkBuilder(finger, f"robot_{side}_finger")
        pad = f.box("pad", _PAD_HALF, (0.0, sign * _PAD_HALF[1], _PAD_CENTRE), rubber)
        pad.friction = list(_PAD_FRICTION)
        pad.condim = 4
        # Stiff, high-priority rubber pads: the default soft contact lets a squeezed object sink
        # millimetres into the pads and creep out of the grasp.
        pad.priority = 1
        pad.solref = [0.004, 1.0]
        pad.solimp = [0.95, 0.99, 0.001, 0.5, 2.0]
        bar_y = sign * (2 * _PAD_HALF[1] + _BAR_HALF[1])
        f.box("bar", _BAR_HALF, (0.0, bar_y, _BAR_HALF[2]), metal)
        f.set_mass(_FINGER_MASS)
        builders.append(f)
        fingers.append((finger, sign))
    if look == "mesh":
        _add_hand_look(spec, gripper, fingers, builders)

    # The fingers touch each other when closed on nothing; that is not a collision.
    spec.add_exclude(bodyname1="robot_left_finger", bodyname2="robot_right_finger")
    eq = spec.add_equality(
        name="robot_finger_symmetry",
        type=mujoco.mjtEq.mjEQ_JOINT,
        name1=GRIPPER_FINGER_JOINTS[1],
        name2=GRIPPER_FINGER_JOINTS[0],
    )
    eq.solref = [0.005, 1.0]
    width = spec.add_tendon(name="robot_gripper_width")
    for jn in GRIPPER_FINGER_JOINTS:
        width.wrap_joint(jn, 1.0)


def _add_hand_look(spec: mujoco.MjSpec, gripper: mujoco.MjsBody, fingers: list[tuple[mujoco.MjsBody, float]],
                   primitives: list[_LinkBuilder]) -> None:
    """The mesh look's gripper: a Robotiq 2F-85-like hand drawn over the gripper's primitives.

    A black coupling on an aluminium plate, a black body rounded at its sides and a dark knuckle block
    across the finger travel; per finger a black knuckle link pinned at both ends, a black fingertip and
    its rubber pad. The shapes ride on the gripper and finger bodies, merged into one mesh per body and
    material, so the fingers' look moves with the finger joints. They are massless and never collide;
    the primitives they replace are hidden (the wrist camera's housing stays drawn).
    """
    black = _material(spec, "robot_hand_black", ROBOTIQ_BLACK_RGBA, 0.35, 0.45)
    grey = _material(spec, "robot_hand_grey", ROBOTIQ_GREY_RGBA, 0.45, 0.55)
    silver = _material(spec, "robot_hand_silver", ROBOTIQ_SILVER_RGBA, 0.8, 0.8)
    pad = _material(spec, "robot_hand_pad", ROBOTIQ_PAD_RGBA, 0.05, 0.1)
    for builder in primitives:
        for geom, _ in builder.geoms:
            if not geom.name.endswith("camera_housing"):
                geom.group = _HIDDEN_GROUP

    shapes: dict[tuple[str, str], tuple[mujoco.MjsBody, SolidMesh]] = {}

    def look(body: mujoco.MjsBody, material: str) -> SolidMesh:
        return shapes.setdefault((body.name, material), (body, SolidMesh()))[1]

    along_x = _quat_ry(math.pi / 2)  # a cylinder's axis along x (across the fingers' travel)
    look(gripper, black).cylinder(0.0375, 0.005, pos=[0.0, 0.0, 0.005])
    look(gripper, silver).cylinder(0.039, 0.002, pos=[0.0, 0.0, 0.012])
    # The body: a stadium seen from the front (a box between two cylinders along x).
    look(gripper, black).box((0.031, 0.030, 0.026), pos=[0.0, 0.0, 0.040])
    look(gripper, grey).box((0.024, 0.060, 0.011), pos=[0.0, 0.0, 0.076])
    for y in (-1.0, 1.0):
        look(gripper, black).cylinder(0.026, 0.031, pos=[0.0, 0.030 * y, 0.040], quat=along_x)
        look(gripper, grey).cylinder(0.011, 0.024, pos=[0.0, 0.060 * y, 0.076], quat=along_x)
        look(gripper, silver).cylinder(0.005, 0.026, pos=[0.0, 0.036 * y, 0.080], quat=along_x, segments=16)
    for finger, sign in fingers:
        # u: outwards from the pad's face; z: down from the housing's bottom
        top, low = (sign * 0.036, -0.004), (sign * 0.021, 0.027)
        dy, dz = low[0] - top[0], low[1] - top[1]
        look(finger, black).box((0.012, 0.0045, 0.5 * math.hypot(dy, dz)),
                                pos=[0.0, 0.5 * (top[0] + low[0]), 0.5 * (top[1] + low[1])],
                                quat=_quat_rx(math.atan2(-dy, dz)))
        for y, z in (top, low):
            look(finger, silver).cylinder(0.0045, 0.0135, pos=[0.0, y, z], quat=along_x, segments=16)
        look(finger, black).box((0.011, 0.006, 0.021), pos=[0.0, sign * 0.014, 0.0395])
        look(finger, pad).box(_PAD_HALF, pos=[0.0, sign * _PAD_HALF[1], _PAD_CENTRE])

    # One mesh per body and material: a handful of draw calls instead of twenty finely tessellated shapes.
    for (body_name, material), (body, solid) in shapes.items():
        name = f"{body_name}_look_{material.removeprefix('robot_hand_')}"
        mesh = spec.add_mesh(name=name)
        mesh.uservert = solid.vertices.ravel()
        mesh.userface = solid.faces.ravel()
        mesh.usernormal = solid.normals.ravel()
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        geom = body.add_geom(name=name, type=_GEOM.mjGEOM_MESH, meshname=name, material=material)
        geom.contype = 0
        geom.conaffinity = 0
        geom.group = _VISUAL_GROUP
        geom.mass = 0.0


def _add_arm_meshes(spec: mujoco.MjSpec, links: list[_LinkBuilder]) -> None:
    """The mesh look: the UR5e's visual meshes on the arm bodies; the arm's primitives hidden."""
    meshes = arm_meshes()
    for name, m in meshes.materials.items():
        _material(spec, f"robot_ur_{name}", np.array(m.rgba), m.specular, m.shininess)
    for link in links:
        for geom, _ in link.geoms:
            geom.group = _HIDDEN_GROUP
        for k, part in enumerate(meshes.parts[link.name]):
            mesh = spec.add_mesh(name=f"{link.name}_mesh_{k}")
            mesh.file, data = msh_file(part.vertices, part.faces)
            spec.assets = {**spec.assets, mesh.file: data}
            # Shell inertia needs no closed surface; the geom's zero mass makes it weightless anyway.
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
            geom = link.body.add_geom(name=f"{link.name}_mesh_{k}", type=_GEOM.mjGEOM_MESH, meshname=mesh.name,
                                      material=f"robot_ur_{part.material}")
            geom.contype = 0
            geom.conaffinity = 0
            geom.group = _VISUAL_GROUP
            geom.mass = 0.0


def robot_spec(look: str = "mesh") -> mujoco.MjSpec:
    """The UR5e with its gripper as a standalone spec: body ``robot_base`` at the world origin.

    Args:
        look: how the arm is drawn, one of :data:`~samplehd.robot.constants.ROBOT_LOOKS` (the physics is
            the same for all).

    Raises:
        ConfigError: unknown look.
    """
    if look not in ROBOT_LOOKS:
        raise ConfigError(f"robot look {look!r} is unknown; valid: {', '.join(ROBOT_LOOKS)}")
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.copy_during_attach = True
    grey = _material(spec, "robot_grey", UR_GREY_RGBA, 0.5, 0.6)
    cap = _material(spec, "robot_cap", UR_CAP_RGBA, 0.4, 0.5)
    ring = _material(spec, "robot_ring", UR_RING_RGBA, 0.6, 0.7)
    dark = _material(spec, "robot_dark", UR_DARK_RGBA, 0.3, 0.3)
    metal = _material(spec, "robot_metal", np.array([0.55, 0.56, 0.58, 1.0]), 0.8, 0.8)
    rubber = _material(spec, "robot_rubber", np.array([0.08, 0.08, 0.08, 1.0]), 0.1, 0.1)

    base = spec.worldbody.add_body(name=ROBOT_BODY)
    links = [_LinkBuilder(base, ROBOT_BODY)]
    parent = base
    pos, quat = [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]
    for i, (link_name, joint_name) in enumerate(zip(LINK_NAMES, JOINT_NAMES, strict=True)):
        body = parent.add_body(name=link_name, pos=pos, quat=quat)
        body.gravcomp = 1.0
        joint = body.add_joint(
            name=joint_name,
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=[0.0, 0.0, 1.0],
            range=list(JOINT_LIMITS[i]),
            armature=float(JOINT_ARMATURE[i]),
            damping=float(JOINT_DAMPING[i]),
        )
        joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        # Gravity compensation is the servo's job, so it counts against the joint torque limit.
        joint.actgravcomp = True
        joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_TRUE
        joint.actfrcrange = [-float(TORQUE_LIMITS[i]), float(TORQUE_LIMITS[i])]
        links.append(_LinkBuilder(body, link_name))
        parent = body
        # The next body sits at the fixed part of this joint's DH transform: Tz(d) Tx(a) Rx(alpha).
        pos, quat = [float(DH_A[i]), 0.0, float(DH_D[i])], _quat_rx(float(DH_ALPHA[i]))
    wrist_3 = parent
    wrist_3.add_site(name="flange", pos=[0.0, 0.0, float(DH_D[5])], size=[0.005, 0, 0], rgba=[0.1, 0.1, 1, 0.0])

    _add_arm_geometry(links, grey, cap, ring, dark)
    for link, mass in zip(links, LINK_MASSES, strict=True):
        link.set_mass(float(mass))
    if look == "mesh":
        _add_arm_meshes(spec, links)
    _add_gripper(spec, wrist_3, dark, metal, rubber, look)

    for name, joint_name, kp, vmax in zip(POSITION_ACTUATORS, JOINT_NAMES, ARM_KP, SPEED_LIMITS, strict=True):
        act = spec.add_actuator(name=name, target=joint_name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_intvelocity(kp=float(kp), kv=0.0)
        act.ctrlrange = [-float(vmax), float(vmax)]
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.actrange = list(JOINT_LIMITS[JOINT_NAMES.index(joint_name)])
        act.actlimited = mujoco.mjtLimited.mjLIMITED_TRUE
    for name, joint_name, kv, vmax in zip(VELOCITY_ACTUATORS, JOINT_NAMES, ARM_KV, SPEED_LIMITS, strict=True):
        act = spec.add_actuator(name=name, target=joint_name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_velocity(kv=float(kv))
        act.ctrlrange = [-float(vmax), float(vmax)]
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    # The gripper actuator comes last, so ctrl[12] is the gripper opening width.
    act = spec.add_actuator(name=GRIPPER_ACTUATOR, target="robot_gripper_width", trntype=mujoco.mjtTrn.mjTRN_TENDON)
    act.set_to_position(kp=_GRIPPER_KP, kv=0.0)
    act.ctrlrange = [0.0, GRIPPER_STROKE]
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.forcerange = [-GRIPPER_FORCE, GRIPPER_FORCE]
    act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE

    return spec


# The robot's spec per look, made once per thread; every world attaches a copy of it, so that it gets
# the same robot without building its meshes and bodies again in Python (~13 ms a world).
_KEPT = threading.local()


def _kept_robot_spec(look: str) -> mujoco.MjSpec:
    kept = getattr(_KEPT, "specs", None)
    if kept is None:
        kept = _KEPT.specs = {}
    if look not in kept:
        kept[look] = robot_spec(look)
    return kept[look].copy()


def add_robot(
    parent: mujoco.MjsBody,
    pos: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
    quat: Sequence[float] | np.ndarray = ROBOT_BASE_QUAT,
    look: str = "mesh",
    *,
    spec: mujoco.MjSpec,
) -> mujoco.MjsBody:
    """Attach the UR5e with its gripper to ``parent``.

    Args:
        parent: body of the world spec that carries the robot (e.g. the worldbody).
        pos: position of the robot base frame (DH frame 0) in ``parent``'s frame [m].
        quat: orientation (w, x, y, z) of the base frame in ``parent``'s frame.
        look: how the arm is drawn (:func:`robot_spec`).
        spec: the spec ``parent`` belongs to: it gets the robot's mesh files (in-memory assets).

    Returns:
        The attached root body ``robot_base``.
    """
    warnings.filterwarnings("ignore", message=_EMPTY_PREFIX_WARNING)
    frame = parent.add_frame(pos=list(map(float, pos)), quat=list(map(float, quat)))
    robot = _kept_robot_spec(look)
    spec.assets = {**spec.assets, **robot.assets}
    # MuJoCo also reports the prefix-less attachment through its C warning handler (stdout and
    # MUJOCO_LOG.TXT); silence it for this call only.
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda _msg: None)
    try:
        body = frame.attach_body(robot.body(ROBOT_BODY), "", "")
    finally:
        mujoco.set_mju_user_warning(previous)
    return body
