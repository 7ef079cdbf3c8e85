"""The planner's collision queries on the pruned model copy give exactly the full model's answers."""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import mujoco
import numpy as np

from samplehd.robot.constants import GRIPPER_STROKE, HOME_QPOS
from samplehd.world.collision import CollisionChecker, Held, pruned_collision_model


def test_the_pruned_copy_skips_only_pairs_without_a_kept_body(shop_scene) -> None:
    model, data, bodies, _ = shop_scene
    pruned = pruned_collision_model(model, bodies.robot_bodies)
    full, cut = mujoco.MjData(model), mujoco.MjData(pruned)
    for d, m in ((full, model), (cut, pruned)):
        d.qpos[:] = data.qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
    keep = np.zeros(model.nbody, dtype=bool)
    keep[list(bodies.robot_bodies)] = True

    def kept(d: mujoco.MjData) -> list[tuple[int, int, float]]:
        g = d.contact.geom
        return [(int(a), int(b), float(x)) for (a, b), x in zip(g, d.contact.dist, strict=True)
                if keep[model.geom_bodyid[a]] or keep[model.geom_bodyid[b]]]

    assert full.ncon > cut.ncon  # the objects' contacts with the table and each other are gone
    assert kept(full) == kept(cut) == [(int(a), int(b), float(x)) for (a, b), x in
                                       zip(cut.contact.geom, cut.contact.dist, strict=True)]
    assert np.array_equal(model.geom_contype, pruned_collision_model(model, ()).geom_contype >> 1)


def test_pruned_queries_equal_the_full_models(shop_scene) -> None:
    """Random arm poses, open and closed fingers, with and without a held object (one that reaches into
    its neighbour): the same offending contacts, depths and order."""
    model, data, bodies, robot = shop_scene
    full = CollisionChecker(model, data, bodies, robot, prune=False)
    pruned = CollisionChecker(model, data, bodies, robot)
    rng = np.random.default_rng(5)
    # the box held 4 cm lower than it stands, pressed into the table and beside the bowl
    tcp = np.eye(4)
    tcp[:3, :3] = data.site_xmat[robot.tcp_site].reshape(3, 3)
    tcp[:3, 3] = data.site_xpos[robot.tcp_site]
    box = np.eye(4)
    box[:3, 3] = data.xpos[bodies.object_body[2]] - (0.0, 0.0, 0.04)
    helds = [None, Held(2, np.linalg.solve(tcp, box)), Held(0, np.linalg.solve(tcp, box)), None]
    offending = 0
    for k in range(120):
        q = HOME_QPOS + rng.normal(0.0, 0.6, 6)
        opening = float(rng.uniform(0.0, GRIPPER_STROKE))
        held = helds[k % len(helds)]
        a = full.contacts(q, opening, held, allow_objects_with_gripper=(1,) if k % 3 else ())
        b = pruned.contacts(q, opening, held, allow_objects_with_gripper=(1,) if k % 3 else ())
        assert a == b, (k, a, b)
        offending += bool(a)
    assert offending > 10  # the poses do collide
    # the held object's geoms collide with the table only while it is held
    assert pruned.contacts(HOME_QPOS, GRIPPER_STROKE, helds[1]) == full.contacts(HOME_QPOS, GRIPPER_STROKE, helds[1])
    assert pruned.contacts(HOME_QPOS, GRIPPER_STROKE) == full.contacts(HOME_QPOS, GRIPPER_STROKE)



def test_a_self_contact_shallower_than_the_margin_offends(shop_scene) -> None:
    """The safety monitor stops the arm on any self-contact (``min_penetration`` 0): the planner must
    not accept one that its margin for the scene would let pass. The elbow folds until the wrist
    just touches the upper arm."""
    model, data, bodies, robot = shop_scene
    checker = CollisionChecker(model, data, bodies, robot)
    arm = np.zeros(model.nbody, dtype=bool)
    arm[list(bodies.robot_bodies)] = True
    scratch = mujoco.MjData(model)

    def self_depth(q: np.ndarray) -> float:
        scratch.qpos[:] = data.qpos
        scratch.qpos[robot.arm_qpos] = q
        mujoco.mj_kinematics(model, scratch)
        mujoco.mj_collision(model, scratch)
        pair = model.geom_bodyid[scratch.contact.geom]
        own = arm[pair[:, 0]] & arm[pair[:, 1]]
        return float(-scratch.contact.dist[own].min()) if own.any() else 0.0

    open_, folded = (np.array([2.734, -1.94, elbow, -2.47, -1.57, -1.391]) for elbow in (2.6, 3.1))
    assert self_depth(open_) == 0.0 < checker.margin < self_depth(folded)
    lo, hi = 0.0, 1.0
    while True:  # bisect to a touch shallower than the margin
        mid = (lo + hi) / 2
        depth = self_depth(open_ + mid * (folded - open_))
        if 0.0 < depth < checker.margin:
            break
        lo, hi = (mid, hi) if depth == 0.0 else (lo, mid)
    q = open_ + mid * (folded - open_)
    (a, b, dist), = checker.contacts(q, 0.0)
    assert arm[a] and arm[b] and dist == -depth
    assert checker.free(open_, 0.0)
