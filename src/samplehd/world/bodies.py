"""The model index of a compiled scene and geometric facts about its objects read from the model and
its state.

Body naming lives here (:func:`object_body_name`), so every stage finds scene objects the same way.

Everything here works from MuJoCo's own geoms, so it holds for procedural and imported objects alike:
object bounding boxes in the object frame and in the world, contacts between objects, the robot's
and the gripper's bodies.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from samplehd.catalogue import ObjectFacts
from samplehd.fixedmath import dot, matmul
from samplehd.physics import awake_contacts

__all__ = [
    "ObjectBox",
    "SceneBodies",
    "contact_pairs",
    "grasped_object",
    "object_body_name",
    "object_footprint",
    "object_local_box",
    "object_pose",
    "object_world_box",
    "object_world_hull_box",
    "quat_tilt",
]


def object_body_name(index: int) -> str:
    """Name of the MuJoCo body of scene object `index`."""
    return f"object_{index}"


@dataclass(frozen=True)
class ObjectBox:
    """An axis-aligned box.

    Attributes:
        lo: lower corner (x, y, z) [m].
        hi: upper corner (x, y, z) [m].
    """

    lo: np.ndarray
    hi: np.ndarray

    @property
    def center(self) -> np.ndarray:
        return (self.lo + self.hi) / 2.0

    @property
    def half(self) -> np.ndarray:
        return (self.hi - self.lo) / 2.0

    def contains_xy(self, xy: np.ndarray, margin: float = 0.0) -> bool:
        """Whether (x, y) lies inside the box shrunk by ``margin`` [m] on every side."""
        return bool(np.all(xy[:2] >= self.lo[:2] + margin) and np.all(xy[:2] <= self.hi[:2] - margin))


_CORNER_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


def _geom_corners(model: mujoco.MjModel, g: int | np.ndarray) -> np.ndarray:
    """The 8 corners of geom ``g``'s bounding box in its frame, (8, 3); of geoms ``g``, (G, 8, 3) [m]."""
    c, h = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
    if np.ndim(g):
        return c[:, None, :] + _CORNER_SIGNS[None] * h[:, None, :]
    return c + _CORNER_SIGNS * h


class SceneBodies:
    """Body and geom ids of a compiled scene: objects, robot, gripper, table.

    Args:
        model: the compiled world.
        num_objects: number of scene objects (bodies ``object_0`` …).
    """

    def __init__(self, model: mujoco.MjModel, num_objects: int) -> None:
        self.model = model
        self.num_objects = num_objects
        self.object_body = np.array(
            [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, object_body_name(i)) for i in range(num_objects)],
            dtype=int,
        )
        root = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "robot_base")
        self.robot_bodies = set()
        if root >= 0:
            for b in range(model.nbody):
                a = b
                while a > 0 and a != root:
                    a = int(model.body_parentid[a])
                if a == root:
                    self.robot_bodies.add(b)
        self.gripper_bodies = set()
        for j in range(model.njnt):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or ""
            if "finger" in name:
                self.gripper_bodies.add(int(model.jnt_bodyid[j]))
        # The finger bodies' subtrees (pads) belong to the gripper too.
        for b in list(self.robot_bodies):
            a = b
            while a > 0:
                if a in self.gripper_bodies:
                    self.gripper_bodies.add(b)
                    break
                a = int(model.body_parentid[a])
        self.table_body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "table")
        self.body_to_object = {int(b): i for i, b in enumerate(self.object_body)}
        self._local_boxes: dict[int, ObjectBox] = {}

    def object_geoms(self, i: int) -> np.ndarray:
        """Geom ids of object ``i`` (its body only; objects are single bodies)."""
        return np.flatnonzero(self.model.geom_bodyid == self.object_body[i])

    def local_box(self, i: int) -> ObjectBox:
        """Bounding box of object ``i`` in its own frame [m] (cached)."""
        if i not in self._local_boxes:
            self._local_boxes[i] = object_local_box(self.model, self, i)
        return self._local_boxes[i]


def object_local_box(model: mujoco.MjModel, bodies: SceneBodies, i: int) -> ObjectBox:
    """Bounding box of object ``i``'s collision geoms in the object (body) frame [m]."""
    pts = []
    geoms = bodies.object_geoms(i)
    coll = [g for g in geoms if model.geom_contype[g] or model.geom_conaffinity[g]]
    for g in coll or geoms:
        mat = np.empty(9)
        mujoco.mju_quat2Mat(mat, model.geom_quat[g])
        pts.append(matmul(_geom_corners(model, g), mat.reshape(3, 3).T) + model.geom_pos[g])
    p = np.concatenate(pts)
    return ObjectBox(p.min(axis=0), p.max(axis=0))


def object_world_box(model: mujoco.MjModel, data: mujoco.MjData, bodies: SceneBodies, i: int) -> ObjectBox:
    """World axis-aligned bounding box of object ``i``'s collision geoms in the current state [m]."""
    geoms = bodies.object_geoms(i)
    coll = [g for g in geoms if model.geom_contype[g] or model.geom_conaffinity[g]]
    g = np.asarray(coll or geoms, dtype=int)
    rots = np.swapaxes(data.geom_xmat[g].reshape(-1, 3, 3), 1, 2)
    p = (matmul(_geom_corners(model, g), rots) + data.geom_xpos[g][:, None, :]).reshape(-1, 3)
    return ObjectBox(p.min(axis=0), p.max(axis=0))


def object_world_hull_box(model: mujoco.MjModel, data: mujoco.MjData, bodies: SceneBodies, i: int) -> ObjectBox:
    """World axis-aligned bounding box of object ``i``'s collision geoms from their mesh vertices [m].

    :func:`object_world_box` rotates each geom's own bounding box, which MuJoCo keeps in the mesh's
    principal-axes frame: for an irregular convex piece (a scanned bowl's V-HACD hulls) that frame is
    tilted and the box reaches a centimetre below the object. This one is exact for mesh pieces (and
    the same for boxes); it judges a task's end state, where "above" is a millimetre question.
    """
    geoms = bodies.object_geoms(i)
    coll = [g for g in geoms if model.geom_contype[g] or model.geom_conaffinity[g]] or list(geoms)
    pts = []
    for g in coll:
        rot = data.geom_xmat[g].reshape(3, 3)
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            m = int(model.geom_dataid[g])
            local = model.mesh_vert[model.mesh_vertadr[m]: model.mesh_vertadr[m] + model.mesh_vertnum[m]]
        else:
            local = _geom_corners(model, g)
        pts.append(matmul(np.asarray(local, dtype=np.float64), rot.T) + data.geom_xpos[g])
    p = np.concatenate(pts)
    return ObjectBox(p.min(axis=0), p.max(axis=0))


def contact_pairs(model: mujoco.MjModel, data: mujoco.MjData) -> set[tuple[int, int]]:
    """Pairs of bodies (sorted ids) in contact in the current state.

    Bodies asleep in MuJoCo's sleeping islands have no contacts in ``data``; when any is asleep,
    the contacts are computed on an awake copy of the positions instead (``data`` is not touched).
    """
    data = awake_contacts(model, data)
    pairs: set[tuple[int, int]] = set()
    for k in range(data.ncon):
        c = data.contact[k]
        if c.dist > 1e-3:
            continue
        a, b = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
        pairs.add((min(a, b), max(a, b)))
    return pairs


def quat_tilt(q0: np.ndarray, q1: np.ndarray) -> float:
    """Angle between the z axes of two orientations (w, x, y, z) [rad]: how far an object tipped."""
    z = []
    for q in (q0, q1):
        m = np.empty(9)
        mujoco.mju_quat2Mat(m, np.asarray(q, dtype=float))
        z.append(m.reshape(3, 3)[:, 2])
    return math.acos(max(-1.0, min(1.0, dot(z[0], z[1]))))


def object_pose(data: mujoco.MjData, bodies: SceneBodies, i: int) -> np.ndarray:
    """World pose (4×4) of object ``i`` in the state ``data``."""
    b = bodies.object_body[i]
    t = np.eye(4)
    t[:3, :3] = data.xmat[b].reshape(3, 3)
    t[:3, 3] = data.xpos[b]
    return t


def object_footprint(
    data: mujoco.MjData, bodies: SceneBodies, k: int, facts: ObjectFacts | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centre xy, 2×2 rotation, half sizes) of object k's footprint rectangle in the world."""
    t = object_pose(data, bodies, k)
    yaw = math.atan2(t[1, 0], t[0, 0])
    rot = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    if facts is not None:
        c_local, half = np.asarray(facts.footprint_center), np.asarray(facts.footprint_half_extents)
    else:
        box = bodies.local_box(k)
        c_local, half = box.center[:2], box.half[:2]
    if abs(t[2, 2]) < 0.9:  # tipped over: fall back to the world box
        wb = object_world_box(bodies.model, data, bodies, k)
        return wb.center[:2], np.eye(2), wb.half[:2]
    return t[:2, 3] + matmul(rot, c_local), rot, half


def grasped_object(model: mujoco.MjModel, data: mujoco.MjData, finger_bodies: tuple[int, int],
                   body_to_object: dict[int, int]) -> int:
    """The scene object touching both fingers, or -1."""
    touching: dict[int, set[int]] = {}
    for k in range(data.ncon):
        c = data.contact[k]
        if c.dist > 1e-3:
            continue
        b1, b2 = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
        for f, o in ((b1, b2), (b2, b1)):
            if f in finger_bodies and o in body_to_object:
                touching.setdefault(body_to_object[o], set()).add(f)
    for obj, fingers in touching.items():
        if len(fingers) == 2:
            return obj
    return -1
