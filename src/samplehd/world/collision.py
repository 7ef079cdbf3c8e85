"""Collision checks of robot configurations with MuJoCo's own collision detection on a scratch
``MjData``: the arm at given joint angles, the fingers at an opening, optionally an object held
rigidly in the gripper. The physics state of the episode is never touched.

Only contacts that involve the robot or the held object can offend, yet MuJoCo's collision pass
would also collide every resting object with the table and its neighbours (a SHOP-VRB shape's
convex hulls: 40-60 contacts, about 85 % of a query's time). A checker therefore collides on a
private copy of the model whose collision bits (``geom_contype``/``geom_conaffinity``, and the
bodies' unions of them) keep every pair with a robot geom or a held-object geom exactly as the
scene's bits decide and drop the pairs of two other geoms: the same offending contacts, the same
depths, in the same order.
"""

from __future__ import annotations

import copy
from collections.abc import Iterable
from dataclasses import dataclass

import mujoco
import numpy as np

from samplehd.fixedmath import matmul
from samplehd.world.bodies import SceneBodies
from samplehd.world.robot_info import RobotInfo

__all__ = ["CollisionChecker", "Held", "pruned_collision_model"]


@dataclass(frozen=True, eq=False)
class Held:
    """An object held rigidly by the gripper.

    Attributes:
        index: scene object index.
        tcp_to_object: 4×4 pose of the object frame in the TCP frame.
    """

    index: int
    tcp_to_object: np.ndarray


def _body_bits(model: mujoco.MjModel) -> None:
    """Set each body's ``body_contype``/``body_conaffinity`` to the union of its geoms' bits, as the
    compiler does."""
    for name in ("contype", "conaffinity"):
        bits = np.zeros(model.nbody, dtype=np.int64)
        np.bitwise_or.at(bits, model.geom_bodyid, getattr(model, f"geom_{name}").astype(np.int64))
        getattr(model, f"body_{name}")[:] = bits


def _pruned_bits(contype: np.ndarray, conaffinity: np.ndarray, kept: np.ndarray | bool
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Geoms' collision bits in a pruned copy: moved one place up, and kept in place too where ``kept``."""
    ct, ca = np.asarray(contype, np.int64), np.asarray(conaffinity, np.int64)
    return np.where(kept, ct | (ct << 1), ct << 1), np.where(kept, ca | (ca << 1), ca)


def pruned_collision_model(model: mujoco.MjModel, keep_bodies: Iterable[int]) -> mujoco.MjModel:
    """A copy of ``model`` whose collision pass skips every geom pair with neither geom in ``keep_bodies``.

    A pair (a, b) collides when ``contype[a] & conaffinity[b]`` or ``contype[b] & conaffinity[a]``.
    Each geom's bits move one place up (bits 1 and above); a geom of ``keep_bodies`` also keeps them
    in place (bits 0 and above): a kept geom's bits against another geom's are the scene's own, and
    two other geoms share no bit. The scene must use bits below 30 only.

    Args:
        model: compiled world (not modified).
        keep_bodies: bodies whose geoms collide as in ``model`` with everything.
    """
    pruned = copy.copy(model)
    ct = model.geom_contype.astype(np.int64)
    ca = model.geom_conaffinity.astype(np.int64)
    if max(int(ct.max(initial=0)), int(ca.max(initial=0))) >= 1 << 30:
        raise ValueError("pruned_collision_model: the scene's collision bits use bit 30 or 31")
    keep = np.zeros(model.nbody, dtype=bool)
    keep[list(keep_bodies)] = True
    kept = keep[model.geom_bodyid]
    pruned.geom_contype[:], pruned.geom_conaffinity[:] = _pruned_bits(ct, ca, kept)
    _body_bits(pruned)
    return pruned


class CollisionChecker:
    """Checks robot configurations against the scene in a given physics state.

    Args:
        model: compiled world.
        data: the current state (object poses are copied from it at construction / :meth:`sync`).
        bodies: body ids of the scene.
        robot: robot addresses.
        margin: penetration depth tolerated [m] (contacts shallower than this are ignored), except
            between two of the robot's own links, which offend at any depth (the safety monitor stops
            the arm on any self-contact).
        object_margin: penetration tolerated between the arm and a scene object [m] (a graze; the
            safety monitor only stops on force there).
        prune: collide on a copy of the model that skips the pairs of two geoms neither of which is
            the robot's or the held object's (:func:`pruned_collision_model`; the same contacts
            offend). Copying costs 2-4 CPU ms: worth it from a few tens of queries on.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, bodies: SceneBodies, robot: RobotInfo,
                 margin: float = 0.0005, object_margin: float = 0.0015, prune: bool = True) -> None:
        self.model, self.bodies, self.robot, self.margin = model, bodies, robot, margin
        self.object_margin = object_margin
        # The base never moves: what touches it touched it in the scene already.
        self.static_robot = {mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "robot_base")}
        self.object_bodies = {int(b) for b in bodies.object_body}
        self._collide_model = pruned_collision_model(model, bodies.robot_bodies) if prune else model
        # the held object whose geoms collide as kept ones in the pruned copy (-1: none)
        self._kept_object = -1
        self.scratch = mujoco.MjData(self._collide_model)
        self.sync(data)
        # Per-body flags, so that contacts are sorted in arrays rather than one by one.
        flags = np.zeros((4, model.nbody), dtype=bool)
        for row, ids in enumerate((self.static_robot, bodies.robot_bodies, self.object_bodies, bodies.gripper_bodies)):
            flags[row, list(ids)] = True
        self._static, self._robot, self._object, self._grip = flags
        self._obj_qpos = {}
        for i, b in enumerate(bodies.object_body):
            j = model.body_jntadr[b]
            self._obj_qpos[i] = int(model.jnt_qposadr[j]) if j >= 0 else -1
        self.checks = 0

    def sync(self, data: mujoco.MjData) -> None:
        """Take object poses (and everything else) from ``data``."""
        self.base_qpos = data.qpos.copy()

    def _keep_held(self, held: Held | None) -> None:
        """Make the held object's geoms collide with everything in the pruned copy (and the last held
        one's no longer)."""
        index = -1 if held is None else held.index
        if self._collide_model is self.model or index == self._kept_object:
            return
        m, src = self._collide_model, self.model
        for i, kept in ((self._kept_object, False), (index, True)):
            if i < 0:
                continue
            g = self.bodies.object_geoms(i)
            m.geom_contype[g], m.geom_conaffinity[g] = _pruned_bits(src.geom_contype[g], src.geom_conaffinity[g], kept)
            b = int(self.bodies.object_body[i])
            for name in ("contype", "conaffinity"):
                getattr(m, f"body_{name}")[b] = np.bitwise_or.reduce(getattr(m, f"geom_{name}")[g], initial=0)
        self._kept_object = index

    def _set(self, q: np.ndarray, opening: float, held: Held | None) -> None:
        d = self.scratch
        d.qpos[:] = self.base_qpos
        d.qpos[self.robot.arm_qpos] = q
        d.qpos[self.robot.finger_qpos] = self.robot.finger_qpos_for(opening)
        mujoco.mj_kinematics(self.model, d)
        if held is not None:
            adr = self._obj_qpos[held.index]
            tcp = np.eye(4)
            tcp[:3, :3] = d.site_xmat[self.robot.tcp_site].reshape(3, 3)
            tcp[:3, 3] = d.site_xpos[self.robot.tcp_site]
            obj = matmul(tcp, held.tcp_to_object)
            quat = np.empty(4)
            mujoco.mju_mat2Quat(quat, obj[:3, :3].reshape(9))
            d.qpos[adr:adr + 3] = obj[:3, 3]
            d.qpos[adr + 3:adr + 7] = quat
            mujoco.mj_kinematics(self.model, d)

    def contacts(
        self,
        q: np.ndarray,
        opening: float,
        held: Held | None = None,
        allow: Iterable[tuple[int, int]] = (),
        allow_objects_with_gripper: Iterable[int] = (),
    ) -> list[tuple[int, int, float]]:
        """Offending contacts at configuration ``q``: (body a, body b, distance [m]).

        A contact offends when it involves the robot or the held object, is deeper than the margin
        (two robot links: at any depth), and is not allowed: robot self-contacts inside the gripper,
        the gripper with the held object, the gripper with objects in ``allow_objects_with_gripper``,
        and the body pairs in ``allow``.
        """
        self._set(q, opening, held)
        self._keep_held(held)
        d, m, b = self.scratch, self.model, self.bodies
        mujoco.mj_collision(self._collide_model, d)
        self.checks += 1
        if d.ncon == 0:
            return []
        held_body = int(b.object_body[held.index]) if held is not None else -2
        dist = d.contact.dist
        body = m.geom_bodyid[d.contact.geom]
        b1, b2 = body[:, 0], body[:, 1]
        r1, r2 = self._robot[b1], self._robot[b2]
        h1, h2 = b1 == held_body, b2 == held_body
        grip_ok = np.zeros(m.nbody, dtype=bool)
        grip_ok[[int(b.object_body[i]) for i in allow_objects_with_gripper]] = True
        if held is not None:
            grip_ok[held_body] = True
        g1, g2 = self._grip[b1], self._grip[b2]
        offends = (
            ((dist <= -self.margin) | (r1 & r2 & (dist <= 0.0)))  # the arm touching itself
            & ~(self._static[b1] | self._static[b2])
            # a graze of the arm on a scene object (not the held one)
            & ~(((r1 & self._object[b2]) | (r2 & self._object[b1])) & (dist > -self.object_margin) & ~h1 & ~h2)
            & (r1 | r2 | h1 | h2)
            & ~(r1 & r2 & g1 & g2)  # inside the gripper
            & ~((g1 & grip_ok[b2]) | (g2 & grip_ok[b1]))
        )
        allowed = {(min(x, y), max(x, y)) for x, y in allow}
        return [(int(b1[k]), int(b2[k]), float(dist[k])) for k in np.flatnonzero(offends)
                if (min(int(b1[k]), int(b2[k])), max(int(b1[k]), int(b2[k]))) not in allowed]

    def free(self, q: np.ndarray, opening: float, held: Held | None = None,
             allow: Iterable[tuple[int, int]] = (), allow_objects_with_gripper: Iterable[int] = ()) -> bool:
        """Whether configuration ``q`` has no offending contact."""
        return not self.contacts(q, opening, held, allow, allow_objects_with_gripper)

    def path_free(self, qs: np.ndarray, opening: float, held: Held | None = None,
                  allow: Iterable[tuple[int, int]] = (), allow_objects_with_gripper: Iterable[int] = (),
                  step: float = 0.03) -> bool:
        """Whether the piecewise-linear joint path through ``qs`` is free, checked every ``step`` [rad]."""
        allow = tuple(allow)
        allow_g = tuple(allow_objects_with_gripper)
        qs = np.asarray(qs)
        for a, c in zip(qs[:-1], qs[1:], strict=False):
            n = max(1, int(np.ceil(np.max(np.abs(c - a)) / step)))
            for s in np.linspace(0.0, 1.0, n + 1)[1:]:
                if not self.free(a + s * (c - a), opening, held, allow, allow_g):
                    return False
        return bool(len(qs) == 0 or self.free(qs[0], opening, held, allow, allow_g))
