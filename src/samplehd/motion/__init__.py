"""Ground-truth motion paths: grasp registry, subtask planner, execution in physics, retries.

Typical use::

    import numpy as np
    from samplehd.motion import plan_and_execute, PathRejected

    try:
        episode = plan_and_execute(scene_spec, task_dict, np.random.default_rng(0), family="place")
    except PathRejected as exc:
        print(exc.reason)          # counted rejection reason, e.g. "no_feasible_grasp"
"""

from samplehd.motion.assist import GraspAssist, add_grasp_welds, compile_scene_with_assist
from samplehd.motion.pipeline import PathConfig, PathRejected, initial_state, plan_and_execute
from samplehd.world.grasps import GRASP_RULES, Grasp, GraspRule, grasp_candidates, register_grasp_rule
from samplehd.world.planner_config import PlannerConfig

__all__ = [
    "GRASP_RULES",
    "Grasp",
    "GraspAssist",
    "GraspRule",
    "PathConfig",
    "PathRejected",
    "PlannerConfig",
    "add_grasp_welds",
    "compile_scene_with_assist",
    "grasp_candidates",
    "initial_state",
    "plan_and_execute",
    "register_grasp_rule",
]
