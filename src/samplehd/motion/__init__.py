"""Ground-truth motion: the subtask planner that yields control targets, trajectories, grasp assist.

The planner (:class:`~samplehd.motion.execute.Rollout`) yields one
:class:`~samplehd.motion.execute.ControlTarget` per control step; :func:`~samplehd.motion.execute.drive`
sends them to a step function. Planning one instruction's path with retries and recording it is
:func:`samplehd.record.paths.plan_and_execute`::

    import numpy as np
    from samplehd.record.paths import PathRejected, plan_and_execute

    try:
        episode = plan_and_execute(scene_spec, task_dict, np.random.default_rng(0), family="place")
    except PathRejected as exc:
        print(exc.reason)          # counted rejection reason, e.g. "no_feasible_grasp"

Grasp candidates and the grasp feasibility query live on the ground floor, :mod:`samplehd.world.grasps`.
"""

from samplehd.motion.assist import GraspAssist, add_grasp_welds, compile_scene_with_assist
from samplehd.motion.execute import (
    AttemptFailed,
    ControlTarget,
    Rollout,
    SubtaskCut,
    drive,
    initial_state,
    step_controller,
)

__all__ = [
    "AttemptFailed",
    "ControlTarget",
    "GraspAssist",
    "Rollout",
    "SubtaskCut",
    "add_grasp_welds",
    "compile_scene_with_assist",
    "drive",
    "initial_state",
    "step_controller",
]
