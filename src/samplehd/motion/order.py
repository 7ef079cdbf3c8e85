"""The order in which the planner picks the objects of a task that moves several (``paths.planner.order``).

``instruction``
    As the task lists them (the language executor's order: scene order of the selected objects).
``nearest``
    SAMPLE-HD's order, for a family whose moved objects are a set (place, remove; stack_three keeps
    its middle-then-top order). Before each pick, the remaining object whose position at the start of the
    episode is nearest (Euclidean distance) to the effector point, SAMPLE-HD's "effector end"
    :data:`EFFECTOR_POINT_OFFSET` beyond the flange on the tool axis, where the arm is when that
    object's approach (GripperMoveAvoid) begins; a tie goes to the one listed first.

That is the order SAMPLE-HD's ``preprocessing/sequence_data_preprocessing.py`` assigns a sequence's
approaches to the task's objects when it computes each subtask's target object and mask: for each
GripperMoveAvoid in turn, ``UR5e.effector_end`` of the ``robot_state`` of its first frame against the
``position`` of the remaining objects in the sequence's first frame, nearest first (``np.argmin``).
Every approach starts at the home pose (the first from the start, each later one after
MoveToDefaultPos), so the order is, in effect, nearest to the home effector point first.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from samplehd.robot.constants import TCP_OFFSET
from samplehd.world.planner_config import PICK_ORDERS

__all__ = ["EFFECTOR_POINT_OFFSET", "effector_point", "next_object", "pick_order"]

# SAMPLE-HD's effector point: this far beyond the flange along the tool z axis (its utils/robot.py,
# UR5e.effector_transform) [m]; samplehd's TCP is TCP_OFFSET beyond the flange.
EFFECTOR_POINT_OFFSET = 0.09


def effector_point(tcp_pos: np.ndarray, tcp_rot: np.ndarray) -> np.ndarray:
    """SAMPLE-HD's effector point [m] from the TCP position (3,) and orientation (3, 3), same frame."""
    return np.asarray(tcp_pos, float) + (EFFECTOR_POINT_OFFSET - TCP_OFFSET) * np.asarray(tcp_rot, float)[:, 2]


def next_object(order: str, remaining: Sequence[int], effector: np.ndarray | None = None,
                start_positions: np.ndarray | None = None) -> int:
    """The object of ``remaining`` (non-empty, in the task's order) to pick next.

    Args:
        order: one of :data:`~samplehd.world.planner_config.PICK_ORDERS`.
        remaining: the task's objects not moved yet, in the task's order.
        effector: the effector point now (``nearest`` only) [m].
        start_positions: (N, 3) every scene object's position at the start of the episode, same
            frame as ``effector`` (``nearest`` only) [m].

    Raises:
        ValueError: an unknown order, no object left, or ``nearest`` without positions.
    """
    if not remaining:
        raise ValueError("no object left to pick")
    if order == "instruction":
        return int(remaining[0])
    if order == "nearest":
        if effector is None or start_positions is None:
            raise ValueError("order 'nearest' needs the effector point and the objects' start positions")
        pos = np.asarray(start_positions, float)[list(remaining)]
        return int(remaining[int(np.argmin(np.linalg.norm(pos - np.asarray(effector, float), axis=1)))])
    raise ValueError(f"order {order!r}; valid: {', '.join(PICK_ORDERS)}")


def pick_order(order: str, objects: Sequence[int], effectors: Sequence[np.ndarray] | None = None,
               start_positions: np.ndarray | None = None) -> list[int]:
    """The whole order, given the effector point at each approach's start (``effectors[k]`` before the
    k-th pick): what SAMPLE-HD's preprocessing computes from a recorded sequence."""
    remaining, out = list(objects), []
    for k in range(len(remaining)):
        i = next_object(order, remaining, None if effectors is None else effectors[k], start_positions)
        remaining.remove(i)
        out.append(i)
    return out
