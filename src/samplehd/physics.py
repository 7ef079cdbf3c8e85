"""Physics helpers shared by the robot, the tasks and the scenes: MuJoCo's sleeping islands.

Resting objects sleep (``WorldConfig.sleep``): a sleeping body costs no collision or constraint
work until something awake touches or pulls it, and it has no contacts in ``data.contact``.
"""

from __future__ import annotations

import mujoco

__all__ = ["awake_contacts", "wake_all"]

_AWAKE = -(1 + mujoco.mjMINAWAKE)  # MuJoCo's tree_asleep value of a fully awake tree


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
