"""Fixed geometry of the kitchen table, the robot's place on it, and the table parts.

World frame: z up, metres. The operator stands in front of the table (+x) looking towards the
robot, which stands at the back edge (-x). From the operator's viewpoint, *left* is -y, *right* is
+y, *front* is +x (towards the operator) and *back* is -x (towards the robot).

The workspace is the rectangle of the table top where objects are placed: reachable by the arm and
clear of its base. Table parts are halves of the workspace separated by a neutral band: an object
whose centre lies in the band belongs to neither half on that axis.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "DIRECTIONS",
    "Directions",
    "LAYOUT",
    "OPPOSITE_PART",
    "TABLE_PARTS",
    "TableLayout",
    "table_parts_of",
]

TABLE_PARTS = ("left", "right", "front", "back")
OPPOSITE_PART = {"left": "right", "right": "left", "front": "back", "back": "front"}

# A scene's direction vectors by name (CLEVR's ``directions`` of scenes.json): unit vectors, world frame.
Directions = Mapping[str, Sequence[float]]

# Unit vectors in the ground plane, from the operator's viewpoint (CLEVR's "directions").
DIRECTIONS: dict[str, tuple[float, float, float]] = {
    "left": (0.0, -1.0, 0.0),
    "right": (0.0, 1.0, 0.0),
    "front": (1.0, 0.0, 0.0),
    "behind": (-1.0, 0.0, 0.0),
    "above": (0.0, 0.0, 1.0),
    "below": (0.0, 0.0, -1.0),
}


@dataclass(frozen=True)
class TableLayout:
    """Dimensions of the table and workspace.

    Attributes:
        table_size: full extent of the table top along x and y [m].
        table_height: height of the table top above the floor [m].
        table_thickness: thickness of the table top [m].
        robot_base: position of the robot base on the table top (x, y) [m].
        workspace_min: lower corner (x, y) of the object workspace [m].
        workspace_max: upper corner (x, y) of the object workspace [m].
        band: width of the neutral band between opposite table parts [m].
        reach_min: smallest horizontal distance from the robot base for objects [m].
        reach_max: largest horizontal distance from the robot base for objects [m].
    """

    table_size: tuple[float, float] = (1.0, 1.4)
    table_height: float = 0.75
    table_thickness: float = 0.04
    robot_base: tuple[float, float] = (-0.40, 0.0)
    workspace_min: tuple[float, float] = (-0.15, -0.40)
    workspace_max: tuple[float, float] = (0.30, 0.40)
    band: float = 0.06
    reach_min: float = 0.28
    reach_max: float = 0.72

    def in_reach(self, xy: np.ndarray | tuple[float, float]) -> bool:
        """Whether a point (x, y) on the table is inside the arm's horizontal reach annulus."""
        r = float(np.hypot(xy[0] - self.robot_base[0], xy[1] - self.robot_base[1]))
        return self.reach_min <= r <= self.reach_max

    @property
    def workspace_center(self) -> np.ndarray:
        """Centre (x, y) of the workspace [m]; table parts split around it."""
        return (np.asarray(self.workspace_min) + np.asarray(self.workspace_max)) / 2.0

    @property
    def robot_base_position(self) -> np.ndarray:
        """3-D position of the robot base frame origin in the world [m]."""
        return np.array([self.robot_base[0], self.robot_base[1], self.table_height])

    def part_bounds(self, part: str) -> tuple[np.ndarray, np.ndarray]:
        """Return (lower, upper) corners (x, y) of a table part inside the workspace [m]."""
        lo = np.array(self.workspace_min, dtype=float)
        hi = np.array(self.workspace_max, dtype=float)
        c = self.workspace_center
        h = self.band / 2.0
        if part == "left":
            hi[1] = c[1] - h
        elif part == "right":
            lo[1] = c[1] + h
        elif part == "front":
            lo[0] = c[0] + h
        elif part == "back":
            hi[0] = c[0] - h
        else:
            raise ValueError(f"unknown table part {part!r}; valid: {', '.join(TABLE_PARTS)}")
        return lo, hi


LAYOUT = TableLayout()


def table_parts_of(xy: np.ndarray | tuple[float, float], layout: TableLayout = LAYOUT) -> list[str]:
    """Return the table parts (subset of left/right/front/back) a point (x, y) lies in."""
    x, y = float(xy[0]), float(xy[1])
    c = layout.workspace_center
    h = layout.band / 2.0
    parts: list[str] = []
    if y < c[1] - h:
        parts.append("left")
    elif y > c[1] + h:
        parts.append("right")
    if x > c[0] + h:
        parts.append("front")
    elif x < c[0] - h:
        parts.append("back")
    return parts
