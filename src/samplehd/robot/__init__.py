"""UR5e arm with a parallel-jaw gripper: model, analytic kinematics, control and safety.

Import submodules directly (``samplehd.robot.ur5e``, ``.kinematics``, ``.controller``,
``.safety``, ``.constants``); this package only re-exports the most used names.
"""

from __future__ import annotations

from samplehd.robot.constants import HOME_QPOS, JOINT_NAMES, ROBOT_BASE_QUAT, TCP_OFFSET
from samplehd.robot.kinematics import fk_flange, fk_tcp, ik_flange, ik_tcp
from samplehd.robot.ur5e import add_robot, robot_spec

__all__ = [
    "HOME_QPOS",
    "JOINT_NAMES",
    "ROBOT_BASE_QUAT",
    "TCP_OFFSET",
    "add_robot",
    "fk_flange",
    "fk_tcp",
    "ik_flange",
    "ik_tcp",
    "robot_spec",
]
