"""Constants of the UR5e arm and its parallel-jaw gripper.

Kinematics are Universal Robots' published standard Denavit–Hartenberg parameters of the UR5e;
frame i follows frame i-1 by ``Rz(q_i) · Tz(d_i) · Tx(a_i) · Rx(alpha_i)``. The robot base frame
is DH frame 0 (z up through the shoulder-pan axis); the flange frame is DH frame 6 (z pointing out
of the tool flange, the gripper's approach direction).

Masses are those of UR's URDF description; limits are from the UR5e technical specification.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "ARM_KP",
    "ARM_KV",
    "DH_A",
    "DH_ALPHA",
    "DH_D",
    "GRIPPER_ACTUATOR",
    "GRIPPER_FINGER_JOINTS",
    "GRIPPER_FORCE",
    "GRIPPER_MASS",
    "GRIPPER_STROKE",
    "HOME_QPOS",
    "JOINT_ARMATURE",
    "JOINT_DAMPING",
    "JOINT_LIMITS",
    "JOINT_NAMES",
    "LINK_MASSES",
    "LINK_NAMES",
    "NUM_JOINTS",
    "POSITION_ACTUATORS",
    "ROBOT_BASE_QUAT",
    "ROBOT_BODY",
    "ROBOTIQ_BLACK_RGBA",
    "ROBOTIQ_GREY_RGBA",
    "ROBOTIQ_PAD_RGBA",
    "ROBOTIQ_SILVER_RGBA",
    "ROBOT_LOOKS",
    "SPEED_LIMITS",
    "TCP_OFFSET",
    "TORQUE_LIMITS",
    "UR_CAP_RGBA",
    "UR_DARK_RGBA",
    "UR_GREY_RGBA",
    "UR_RING_RGBA",
    "VELOCITY_ACTUATORS",
    "WRIST_CAMERA",
]

NUM_JOINTS = 6

# Standard DH parameters of the UR5e [m, rad].
DH_D = np.array([0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996])
DH_A = np.array([0.0, -0.425, -0.3922, 0.0, 0.0, 0.0])
DH_ALPHA = np.array([np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0])

JOINT_NAMES: tuple[str, ...] = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)
ROBOT_BODY = "robot_base"
# How the arm is drawn: the UR5e's real visual meshes, or the primitive shapes its physics uses.
ROBOT_LOOKS: tuple[str, ...] = ("mesh", "primitive")
LINK_NAMES: tuple[str, ...] = (
    "robot_shoulder_link",
    "robot_upper_arm_link",
    "robot_forearm_link",
    "robot_wrist_1_link",
    "robot_wrist_2_link",
    "robot_wrist_3_link",
)
POSITION_ACTUATORS: tuple[str, ...] = tuple(f"robot_{n.removesuffix('_joint')}_position" for n in JOINT_NAMES)
VELOCITY_ACTUATORS: tuple[str, ...] = tuple(f"robot_{n.removesuffix('_joint')}_velocity" for n in JOINT_NAMES)
GRIPPER_ACTUATOR = "robot_gripper"
GRIPPER_FINGER_JOINTS: tuple[str, str] = ("robot_left_finger_joint", "robot_right_finger_joint")
WRIST_CAMERA = "wrist"  # the camera on the gripper

# Joint position limits [rad]. The elbow is limited to ±180° because the forearm would otherwise
# pass through the upper arm (as on the real arm's recommended configuration).
JOINT_LIMITS = np.array(
    [
        [-2 * np.pi, 2 * np.pi],
        [-2 * np.pi, 2 * np.pi],
        [-np.pi, np.pi],
        [-2 * np.pi, 2 * np.pi],
        [-2 * np.pi, 2 * np.pi],
        [-2 * np.pi, 2 * np.pi],
    ]
)
TORQUE_LIMITS = np.array([150.0, 150.0, 150.0, 28.0, 28.0, 28.0])  # [N·m]
SPEED_LIMITS = np.full(NUM_JOINTS, np.pi)  # 180°/s [rad/s]

# Link masses [kg] (base, shoulder, upper arm, forearm, wrist 1, wrist 2, wrist 3), UR's URDF.
LINK_MASSES = np.array([4.0, 3.761, 8.058, 2.846, 1.37, 1.3, 0.365])
# Reflected rotor inertia [kg·m²] and viscous friction [N·m·s/rad] of each joint.
JOINT_ARMATURE = np.array([0.1, 0.1, 0.1, 0.05, 0.05, 0.05])
JOINT_DAMPING = np.array([2.0, 2.0, 2.0, 0.5, 0.5, 0.5])
# Servo gains: stiffness [N·m/rad] of the position servos and gain [N·m·s/rad] of the velocity
# servos that track the interpolated target's velocity (feed-forward, so ramps do not lag).
ARM_KP = np.array([2500.0, 2500.0, 2500.0, 600.0, 600.0, 600.0])
ARM_KV = np.array([150.0, 150.0, 120.0, 20.0, 20.0, 20.0])

# Gripper: opening width 0 (closed) … GRIPPER_STROKE (open) [m]; squeeze force per finger [N].
GRIPPER_STROKE = 0.085
GRIPPER_FORCE = 85.0
GRIPPER_MASS = 0.9  # [kg], coupling + housing + fingers
# Tool centre point: midway between the finger pads, along the flange z axis [m].
TCP_OFFSET = 0.13

# Home: elbow up, the arm reaching towards +x of the base frame, the gripper pointing straight down
# with the TCP 0.45 m in front of the base and 0.35 m above the table, fingers closing along y
# (IK of that pose, rounded) [rad].
HOME_QPOS = np.array([2.8409, -1.7174, 1.7259, -1.5793, -1.5708, -1.8715])

# The base frame is parallel to the world frame: the base stands at the back edge of the table and
# +x of the base frame points over the table towards the operator, so steering commands in the
# base frame read the same as world directions. (w, x, y, z)
ROBOT_BASE_QUAT = np.array([1.0, 0.0, 0.0, 0.0])

# UR e-Series colours (RGBA): light-grey aluminium links, blue-grey joint caps, dark rings.
UR_GREY_RGBA = np.array([0.78, 0.80, 0.82, 1.0])
UR_CAP_RGBA = np.array([0.20, 0.29, 0.42, 1.0])
UR_RING_RGBA = np.array([0.30, 0.32, 0.35, 1.0])
UR_DARK_RGBA = np.array([0.12, 0.12, 0.13, 1.0])
# Robotiq 2F-85-like hand of the mesh look: black housing and fingers, dark-grey knuckle block,
# aluminium coupling plate and pins, dark rubber pads.
ROBOTIQ_BLACK_RGBA = np.array([0.05, 0.05, 0.055, 1.0])
ROBOTIQ_GREY_RGBA = np.array([0.22, 0.23, 0.25, 1.0])
ROBOTIQ_SILVER_RGBA = np.array([0.68, 0.69, 0.71, 1.0])
ROBOTIQ_PAD_RGBA = np.array([0.13, 0.13, 0.14, 1.0])
