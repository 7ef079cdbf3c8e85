"""UR5e arm with a parallel-jaw gripper: model, analytic kinematics, control and safety.

Submodules: :mod:`~samplehd.robot.constants` (DH parameters, limits, names),
:mod:`~samplehd.robot.ur5e` (``add_robot``), :mod:`~samplehd.robot.meshes` (the UR5e's visual meshes),
:mod:`~samplehd.robot.solids` (meshes of boxes and cylinders, for the hand's look),
:mod:`~samplehd.robot.kinematics` (FK/IK),
:mod:`~samplehd.robot.controller` (``RobotController``), :mod:`~samplehd.robot.safety`
(``SafetyMonitor``). This package re-exports the most used names.
"""

from __future__ import annotations

from samplehd.robot.constants import HOME_QPOS, JOINT_NAMES, ROBOT_BASE_QUAT, TCP_OFFSET
from samplehd.robot.controller import ACTION_MODES, ControlConfig, ControlReport, RobotController
from samplehd.robot.kinematics import fk_flange, fk_tcp, ik_batch, ik_flange, ik_tcp
from samplehd.robot.safety import SafetyConfig, SafetyEvent, SafetyMonitor
from samplehd.robot.ur5e import add_robot, robot_spec

__all__ = [
    "ACTION_MODES",
    "HOME_QPOS",
    "JOINT_NAMES",
    "ROBOT_BASE_QUAT",
    "TCP_OFFSET",
    "ControlConfig",
    "ControlReport",
    "RobotController",
    "SafetyConfig",
    "SafetyEvent",
    "SafetyMonitor",
    "add_robot",
    "fk_flange",
    "fk_tcp",
    "ik_batch",
    "ik_flange",
    "ik_tcp",
    "robot_spec",
]
