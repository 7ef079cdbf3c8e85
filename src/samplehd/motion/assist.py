"""Grasp assist: one rule that decides when an object is held, and the weld that holds it.

Pads pinching a thin rim or a handle far from the object's centre of mass (bowls, trays, pans) make
line or point contacts in MuJoCo that cannot carry the object's torque, so the object pivots out of
the fingers although a real rubber pad would hold it. SAMPLE-HD's Unity paths attach the object in
the same situation. The weld keeps the object exactly where the fingers closed on it; the fingers
still close on it physically and the safety monitor still watches every contact.

The rule (:meth:`GraspAssist.update`), applied at the start of every control step, before its
physics, with that step's gripper command:

- weld object ``i`` when nothing is welded, the arm is not stopped, the command does not open the
  fingers (its opening is at most :data:`OPEN_MARGIN` above the measured one) and both fingers'
  collision geoms lie within :data:`TOUCH_TOLERANCE` of object ``i``'s collision geoms (never its
  visual mesh);
- release the weld when the command opens more than :data:`RELEASE_MARGIN` beyond the command it
  was made with.

The touch decides, not the command's history: a replayed state a fraction of a millimetre off the
recorded one (float32 steering vectors, contacts that amplify it) makes the same verdict at the
same step or the next, where a test of "still closing" or "squeezing" could miss it for good.

It reads only the physics state (through ``qpos``) and the command, so the dataset's rollout
(:class:`samplehd.motion.execute.Rollout`) and the environment (:class:`samplehd.envs.tabletop.TabletopEnv`),
which both call it, weld at the same control step from the same state: recorded actions replay to
the recorded outcome (``samplehd validate --replay``).

The welds are added at model-building time (inactive, one per scene object) by
:func:`add_grasp_welds`; :func:`compile_scene_with_assist` compiles a scene with them. They change no
state dimension (nq, nv, na), so episodes replay on models compiled with or without them.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from samplehd.fixedmath import matmul
from samplehd.physics import wake_all
from samplehd.robot.constants import GRIPPER_FINGER_JOINTS, GRIPPER_STROKE
from samplehd.scene.spec import SceneSpec
from samplehd.scene.world import PlacedObject, build_world, reset_robot_home
from samplehd.world.bodies import object_body_name

__all__ = [
    "GRASP_WELD_PREFIX",
    "RELEASE_MARGIN",
    "OPEN_MARGIN",
    "TOUCH_TOLERANCE",
    "GraspAssist",
    "add_grasp_welds",
    "compile_scene_with_assist",
]

GRASP_WELD_PREFIX = "grasp_weld_"
_GRIPPER_BODY = "robot_gripper"
# Both fingers this close to an object's collision geoms touch it [m]: contacts on thin convex
# pieces flicker from step to step, distances do not.
TOUCH_TOLERANCE = 0.0005
# A command opens the fingers when its opening is this much above the measured one [m].
OPEN_MARGIN = 0.00025
# A weld is released when the command opens this much beyond the command it was made with
# (gripper command units, 2 / stroke per metre: about 2 mm).
RELEASE_MARGIN = 0.05
# What the bodies' bounding spheres add for rounding, so that they only ever rule out what the per-geom
# test would [m].
_SPHERE_SLACK = 1e-6


def add_grasp_welds(spec: mujoco.MjSpec, num_objects: int) -> None:
    """Add one inactive weld ``grasp_weld_{i}`` between the gripper and each object body."""
    for i in range(num_objects):
        eq = spec.add_equality()
        eq.name = f"{GRASP_WELD_PREFIX}{i}"
        eq.type = mujoco.mjtEq.mjEQ_WELD
        eq.objtype = mujoco.mjtObj.mjOBJ_BODY
        eq.name1 = _GRIPPER_BODY
        eq.name2 = object_body_name(i)
        eq.active = False
        eq.solref = [0.01, 1.0]


def compile_scene_with_assist(scene: SceneSpec, timestep: float = 0.002,
                              robot_look: str = "mesh") -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Like ``samplehd.scene.spec.compile_scene`` (arm at home, gripper open), with the grasp welds added."""

    placed = [PlacedObject(o.instance, tuple(o.pos), tuple(o.quat)) for o in scene.objects]
    spec = build_world(placed, scene.world_config(timestep, robot_look))
    add_grasp_welds(spec, len(scene.objects))
    model = spec.compile()
    data = mujoco.MjData(model)
    reset_robot_home(model, data)
    mujoco.mj_forward(model, data)
    return model, data


def _body_radius(model: mujoco.MjModel, geoms: np.ndarray) -> float:
    """Radius about the geoms' body origin that holds every one's bounding sphere [m]."""
    offsets = np.sqrt((model.geom_pos[geoms] ** 2).sum(axis=1)) + model.geom_rbound[geoms]
    return float(offsets.max()) + _SPHERE_SLACK if len(geoms) else 0.0


def _collision_geoms(model: mujoco.MjModel, body: int) -> np.ndarray:
    geoms = np.flatnonzero(model.geom_bodyid == body)
    return geoms[(model.geom_contype[geoms] != 0) | (model.geom_conaffinity[geoms] != 0)]


class GraspAssist:
    """The grasp rule (see the module docstring) and the grasp welds of a compiled model.

    Args:
        model: compiled scene (welds missing: the rule still tells what the fingers touch, but
            nothing is welded).
        num_objects: number of scene objects.
    """

    def __init__(self, model: mujoco.MjModel, num_objects: int) -> None:
        self.model = model
        self.gripper = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, _GRIPPER_BODY)
        self.eq = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, f"{GRASP_WELD_PREFIX}{i}")
                   for i in range(num_objects)]
        joints = [model.joint(name).id for name in GRIPPER_FINGER_JOINTS]
        self.finger_qpos = np.array([model.jnt_qposadr[j] for j in joints])
        self.finger_geoms = tuple(_collision_geoms(model, int(model.jnt_bodyid[j])) for j in joints)
        self.object_geoms = tuple(_collision_geoms(model, model.body(object_body_name(i)).id)
                                  for i in range(num_objects))
        with_geoms = [i for i, g in enumerate(self.object_geoms) if len(g)]
        # Each finger's and each object's collision geoms lie within these radii of its body's origin
        # (offset plus bounding sphere) [m]: a body pair farther apart than their radii and the tolerance
        # has no geom pair close enough, which rules out most control steps before the per-geom test.
        finger_bodies = [int(model.jnt_bodyid[j]) for j in joints]
        object_bodies = [model.body(object_body_name(i)).id for i in with_geoms]
        self._sphere_bodies = np.array(finger_bodies + object_bodies, dtype=int)
        self._sphere_objects = with_geoms
        self._finger_radii = [_body_radius(model, g) for g in self.finger_geoms]
        self._object_radii = [_body_radius(model, self.object_geoms[i]) for i in with_geoms]
        self.active = -1
        self.attach_command = 1.0
        self._fromto = np.zeros(6)

    @property
    def available(self) -> bool:
        """Whether the model has the welds."""
        return self.gripper >= 0 and all(e >= 0 for e in self.eq)

    def opens(self, data: mujoco.MjData, command: float) -> bool:
        """Whether a gripper command in [-1, 1] asks for a wider opening than the fingers have."""
        opening = (command + 1.0) * 0.5 * GRIPPER_STROKE
        return opening > float(data.qpos[self.finger_qpos].sum()) + OPEN_MARGIN

    def touched(self, data: mujoco.MjData, objects: tuple[int, ...] | None = None,
                tolerance: float = TOUCH_TOLERANCE) -> int:
        """The first of ``objects`` (default: all) whose collision geoms lie within ``tolerance`` [m]
        of both fingers' collision geoms in the state ``data.qpos``, or -1."""
        mujoco.mj_kinematics(self.model, data)
        near = self._objects_near(data, tolerance)
        if not near:
            return -1
        # each finger's geoms against the object's: bounding spheres first, then exact distances
        for i in range(len(self.object_geoms)) if objects is None else objects:
            if i in near and all(self._near(data, fingers, self.object_geoms[i], tolerance)
                                 for fingers in self.finger_geoms):
                return i
        return -1

    def _objects_near(self, data: mujoco.MjData, tolerance: float) -> set[int]:
        """The objects whose bounding sphere about their body's origin comes within ``tolerance`` [m] of both
        fingers' (with a micrometre to spare for rounding): only these can have a geom that close to each
        finger's. At most control steps the gripper is near none, and no geom pair is looked at."""
        positions = data.xpos[self._sphere_bodies].tolist()
        nf = len(self._finger_radii)
        fingers = list(zip(positions[:nf], self._finger_radii, strict=True))
        reach = tolerance + _SPHERE_SLACK
        near = set()
        for i, (x, y, z), radius in zip(self._sphere_objects, positions[nf:], self._object_radii, strict=True):
            for (fx, fy, fz), finger_radius in fingers:
                if math.sqrt((fx - x) ** 2 + (fy - y) ** 2 + (fz - z) ** 2) - finger_radius - radius >= reach:
                    break
            else:
                near.add(i)
        return near

    def _gaps(self, data: mujoco.MjData, geoms1: np.ndarray, geoms2: np.ndarray) -> np.ndarray:
        """(len(geoms1), len(geoms2)) gaps between the geoms' bounding spheres [m]."""
        m = self.model
        p1, p2 = data.geom_xpos[geoms1].T, data.geom_xpos[geoms2].T
        # the offsets' lengths as samplehd.fixedmath.norm takes them: squares summed x, y, z
        d = p1[0][:, None] - p2[0][None, :]
        sq = d * d
        d = p1[1][:, None] - p2[1][None, :]
        sq += d * d
        d = p1[2][:, None] - p2[2][None, :]
        sq += d * d
        return np.sqrt(sq) - m.geom_rbound[geoms1][:, None] - m.geom_rbound[geoms2][None, :]

    def _near(self, data: mujoco.MjData, geoms1: np.ndarray, geoms2: np.ndarray, tolerance: float) -> bool:
        m = self.model
        # bounding spheres apart: the geoms are too; the others in turn (row by row) by their distance
        gap = self._gaps(data, geoms1, geoms2)
        for i, j in zip(*np.nonzero(gap < tolerance), strict=True):
            if mujoco.mj_geomDistance(m, data, int(geoms1[i]), int(geoms2[j]), tolerance, self._fromto) < tolerance:
                return True
        return False

    def update(self, data: mujoco.MjData, command: float, stopped: bool = False) -> int:
        """Apply the rule at the start of a control step with gripper command ``command`` (before
        its physics); ``stopped``: the safety monitor has stopped the arm. Returns the welded
        object (-1: none)."""
        if not self.available:
            return -1
        if self.active >= 0:
            if command > self.attach_command + RELEASE_MARGIN:
                self.release(data)
            return self.active
        if stopped or self.opens(data, command):
            return -1
        held = self.touched(data)
        if held >= 0:
            self.attach(data, held)
            self.attach_command = command
        return self.active

    def release_command(self) -> float:
        """A gripper command that surely releases the current weld: beyond the margin by one more
        margin, so that a replay whose weld came a step earlier, at a closing ramp's previous (up to
        a margin wider) command, releases at the same step."""
        return min(1.0, self.attach_command + 3.0 * RELEASE_MARGIN)
    def attach(self, data: mujoco.MjData, i: int) -> bool:
        """Weld object ``i`` to the gripper at their current relative pose; False if unavailable."""
        if not self.available:
            return False
        m = self.model
        b = m.body(object_body_name(i)).id
        rg = data.xmat[self.gripper].reshape(3, 3)
        rel_pos = matmul(rg.T, data.xpos[b] - data.xpos[self.gripper])
        qg_inv = np.empty(4)
        mujoco.mju_negQuat(qg_inv, data.xquat[self.gripper])
        rel_quat = np.empty(4)
        mujoco.mju_mulQuat(rel_quat, qg_inv, data.xquat[b])
        e = self.eq[i]
        # Weld data: anchor (3), relative pose of body2 in body1's frame (pos 3, quat 4), torque scale.
        m.eq_data[e, 0:3] = 0.0
        m.eq_data[e, 3:6] = rel_pos
        m.eq_data[e, 6:10] = rel_quat
        m.eq_data[e, 10] = 1.0
        data.eq_active[e] = 1
        self.active = i
        return True

    def release(self, data: mujoco.MjData) -> None:
        """Switch every grasp weld off."""
        if self.available:
            for e in self.eq:
                data.eq_active[e] = 0
            wake_all(data)
        self.active = -1
