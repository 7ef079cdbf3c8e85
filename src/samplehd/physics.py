"""MuJoCo helpers shared by the robot, the catalogue, the tasks and the scenes: meshes as in-memory
files, and MuJoCo's sleeping islands.

Resting objects sleep (``WorldConfig.sleep``): a sleeping body costs no collision or constraint
work until something awake touches or pulls it, and it has no contacts in ``data.contact``.
"""

from __future__ import annotations

import hashlib

import mujoco
import numpy as np

__all__ = ["awake_contacts", "msh_file", "wake_all"]

_AWAKE = -(1 + mujoco.mjMINAWAKE)  # MuJoCo's tree_asleep value of a fully awake tree


def msh_file(vertices: np.ndarray, faces: np.ndarray | None = None, texcoords: np.ndarray | None = None
             ) -> tuple[str, bytes]:
    """A mesh as a binary ``.msh`` file for a spec's in-memory assets: (its name, derived from its content,
    and its bytes). MuJoCo keeps what it compiled from a file across compiles in the process (a mesh's
    convex hull, normals, inertia), so a mesh given by file is processed once, not at every compile;
    it holds vertices and texture coordinates as float32 either way, so the compiled mesh is the same.
    ``texcoords``: one (u, v) per vertex."""
    v = np.ascontiguousarray(vertices, dtype=np.float32)
    f = np.ascontiguousarray(np.zeros((0, 3)) if faces is None else faces, dtype=np.int32)
    t = np.ascontiguousarray(np.zeros((0, 2)) if texcoords is None else texcoords, dtype=np.float32)
    head = np.array([len(v.reshape(-1, 3)), 0, len(t.reshape(-1, 2)), len(f.reshape(-1, 3))], dtype=np.int32)
    data = head.tobytes() + v.tobytes() + t.tobytes() + f.tobytes()
    return f"samplehd_{hashlib.sha256(data).hexdigest()[:32]}.msh", data


def wake_all(data: mujoco.MjData) -> None:
    """Wake every body and restart every awake body's count-down to sleep.

    A body only wakes by itself when something awake touches or pulls it, and one held still
    counts down to sleep even while held; released from the gripper, it would stay asleep in the
    air. A tree marked awake while asleep is what MuJoCo's own wake pass treats as a user change:
    it wakes the tree's whole island and updates every sleep array consistently.
    """
    asleep = data.tree_asleep >= 0
    data.tree_asleep[~asleep] = _AWAKE
    if asleep.any():
        data.tree_awake[asleep] = 1


def awake_contacts(model: mujoco.MjModel, data: mujoco.MjData) -> mujoco.MjData:
    """``data`` itself when every body is awake, else a copy of its positions with all contacts.

    The copy has positions (``qpos``, mocap poses), kinematics and collisions only.
    """
    if data.ntree_awake >= model.ntree:
        return data
    awake = mujoco.MjData(model)
    awake.qpos[:] = data.qpos
    awake.mocap_pos[:] = data.mocap_pos
    awake.mocap_quat[:] = data.mocap_quat
    mujoco.mj_kinematics(model, awake)
    mujoco.mj_collision(model, awake)
    return awake
