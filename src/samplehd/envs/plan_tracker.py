"""Where an episode stands in the oracle's plan, whatever policy drives.

With the environment option ``oracle_subtask``, every reset plans the instruction's ground-truth path
from the episode's start (the same planner, controller and physics as the dataset's paths, on a copy
of the state). Each step, :class:`PlanTracker` matches the robot's tool position and gripper opening
to the nearest frame of that plan, moving only forwards, and reports that frame's SAMPLE-HD subtask.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from samplehd.record.paths import PathConfig, PathRejected, plan_and_execute
from samplehd.tasks.task import ProgramTask
from samplehd.world.layout import Directions

__all__ = ["PlanTracker", "plan_tracker"]

# How far ahead of the last matched frame the tracker looks (frames of the plan).
_LOOKAHEAD = 120
# Metres of tool distance that one metre of gripper-opening difference counts as.
_GRIPPER_WEIGHT = 2.0


class PlanTracker:
    """Follows a planned episode's frames.

    Args:
        tcp: (T, 3) planned tool positions [m].
        gripper: (T,) planned gripper openings [m].
        subtask_index: (T,) planned subtask indices into ``names``.
        names: subtask names.
    """

    def __init__(self, tcp: np.ndarray, gripper: np.ndarray, subtask_index: np.ndarray,
                 names: tuple[str, ...]) -> None:
        self.tcp = np.asarray(tcp, float)
        self.gripper = np.asarray(gripper, float)
        self.subtask_index = np.asarray(subtask_index, int)
        self.names = tuple(names)
        self.frame = 0

    def update(self, tcp: np.ndarray, gripper: float) -> str:
        """The planned subtask nearest the current state (tool position [m], gripper opening [m])."""
        end = min(len(self.tcp), self.frame + _LOOKAHEAD)
        d = np.linalg.norm(self.tcp[self.frame:end] - tcp, axis=1) + _GRIPPER_WEIGHT * np.abs(
            self.gripper[self.frame:end] - gripper)
        self.frame += int(np.argmin(d))
        return self.names[self.subtask_index[self.frame]]


def plan_tracker(model: mujoco.MjModel, data: mujoco.MjData, scene: Any, task: ProgramTask, family: str,
                 directions: Directions | None, seed: int, physics_hz: float,
                 control_hz: float) -> tuple[PlanTracker | None, str]:
    """Plan the episode from a copy of ``data``; returns (tracker, "") or (None, why not)."""

    copy = mujoco.MjData(model)
    mujoco.mj_copyData(copy, model, data)
    config = PathConfig(physics_hz=physics_hz, control_hz=control_hz)
    try:
        ep = plan_and_execute(scene, task, np.random.default_rng(seed), config, family=family,
                              directions=directions, compiled=(model, copy))
    except PathRejected as exc:
        return None, exc.reason
    f = ep.frames
    return PlanTracker(f["tcp_pos"], f["gripper_opening"], f["subtask_index"], ep.subtasks), ""
