"""Reachability tests for instruction constraints: the horizontal reach annulus, or the analytic IK.

A reachability test is a callable ``reachable(xyz) -> bool`` on a world point [m]: can the gripper
pick or place there? :func:`samplehd.language.constraints.default_reachable` only checks the
horizontal annulus of the table layout; :class:`IKReachable` also asks the UR5e's analytic inverse
kinematics for a top-down grasp at the point and a pre-grasp above it, at any of a few yaws (about
4 ms a point; constraint checks memoise it per scene). Measured on the default layout, the IK
solves every point of a 10 x 17 grid over the workspace, while the annulus admits 149 of the 170:
the annulus is the binding limit there, and the IK matters for custom layouts.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from samplehd.errors import ConfigError
from samplehd.fixedmath import matmul
from samplehd.robot.constants import HOME_QPOS, ROBOT_BASE_QUAT, TCP_OFFSET
from samplehd.robot.kinematics import ik_batch
from samplehd.world.layout import LAYOUT, TableLayout
from samplehd.world.transforms import quat_to_mat

__all__ = ["REACH_MODES", "IKReachable", "make_reachable"]

REACH_MODES = ("annulus", "ik")


@dataclass(frozen=True)
class IKReachable:
    """Reachable when the analytic IK solves a top-down grasp at the point and a pre-grasp above it.

    Attributes:
        layout: table geometry (robot base position).
        pregrasp_height: height of the pre-grasp above the grasp point [m].
        min_height: lowest TCP height above the table top [m] (grasps of flat objects).
        yaws: gripper yaws to try about the vertical [rad]; any one that solves both poses will do.
        within_annulus: also require the layout's reach annulus (the IK alone ignores collisions
            with the robot's own base, so it accepts points the annulus keeps clear).
    """

    layout: TableLayout = LAYOUT
    pregrasp_height: float = 0.10
    min_height: float = 0.02
    yaws: tuple[float, ...] = (0.0, math.pi / 4, math.pi / 2, 3 * math.pi / 4)
    within_annulus: bool = True

    def __call__(self, xyz: Sequence[float]) -> bool:
        if self.within_annulus and not self.layout.in_reach((float(xyz[0]), float(xyz[1]))):
            return False
        base_rot = quat_to_mat(ROBOT_BASE_QUAT)
        base_pos = self.layout.robot_base_position
        z = max(float(xyz[2]), self.layout.table_height + self.min_height)
        poses = []
        for yaw in self.yaws:
            c, s = math.cos(yaw), math.sin(yaw)
            # tool z axis pointing down, rotated by yaw about the vertical
            rot = np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])
            for dz in (0.0, self.pregrasp_height):
                world = np.array([float(xyz[0]), float(xyz[1]), z + dz])
                pose = np.eye(4)
                pose[:3, :3] = matmul(base_rot.T, rot)
                pose[:3, 3] = matmul(base_rot.T, world - base_pos)
                poses.append(pose)
        _, ok = ik_batch(np.array(poses), HOME_QPOS, tool_offset=TCP_OFFSET)
        pairs = ok.reshape(len(self.yaws), 2)
        return bool(np.any(pairs.all(axis=1)))


def make_reachable(mode: str = "annulus", layout: TableLayout = LAYOUT) -> Callable[[Sequence[float]], bool]:
    """Return a reachability test by name: ``"ik"`` (analytic IK) or ``"annulus"`` (layout annulus)."""
    if mode == "ik":
        return IKReachable(layout)
    if mode == "annulus":
        return lambda xyz: layout.in_reach((float(xyz[0]), float(xyz[1])))
    raise ConfigError(f"reach mode {mode!r} is unknown; valid: {', '.join(REACH_MODES)}")
