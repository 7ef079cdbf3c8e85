"""The planner's distances, speeds and search budgets, shared by the feasibility queries (grasps, free
spots) that scenes and instructions ask and by the subtask planner itself."""

from __future__ import annotations

from dataclasses import dataclass

from samplehd.schema import Config, bounded

__all__ = ["PICK_ORDERS", "PlannerConfig"]

# The orders in which the planner moves the objects of a task that moves a set of several (remove,
# place of a plural): ``instruction``: as the task lists them; ``nearest``: SAMPLE-HD's, before each
# pick the remaining object whose start position is nearest the effector point
# (:mod:`samplehd.motion.order`). stack_three always moves middle, then top.
PICK_ORDERS = ("instruction", "nearest")


@dataclass(frozen=True)
class PlannerConfig(Config, section="paths.planner"):
    """Distances, speeds and search budgets of the planner.

    Attributes:
        approach_distance: pre-grasp stand-off along the approach direction [m].
        retreat_distance: straight retreat after releasing [m].
        transport_clearance: held object's bottom above the tallest other object in transport [m].
        min_lift: smallest rise of the held object in MoveUP [m].
        min_transport_height: lowest TCP height above the table in transport [m].
        approach_speed: mean TCP speed of approach/descent lines timed minimum-jerk; 1.875× this is
            their peak, and the cruise speed of long ones [m/s].
        lift_speed: the same for lifts and retreats [m/s].
        line_ramp_time: speed-up and slow-down time of long straight lines (0: minimum-jerk) [s].
        joint_speed: largest joint speed of joint-space moves [rad/s].
        joint_ramp_time: speed-up and slow-down time of long joint-space moves, which cruise at the
            speed limits in between (0: minimum-jerk timing, which peaks at 1.875× the mean speed) [s].
        max_tcp_speed: largest TCP speed in joint-space moves (below the steering scale) [m/s].
        max_tcp_angular_speed: largest TCP angular speed in joint-space moves [rad/s].
        finger_clearance: fingertips above the table at the grasp [m].
        release_gap: object's bottom above its support at release [m].
        max_drop: how much higher the object may be released where the fingers cannot open at the
            support (it drops the rest) [m].
        max_drop_into: the same over a container's opening (put), where the fingers may have to open
            above the rim: the container's walls guide the object in [m].
        close_time: longest duration of CloseGripper [s].
        grip_settle_time: with the grasp assist, CloseGripper ends this long after the object
            attaches (the fingers hold still from then on) [s].
        squeeze_force: finger force once the pads touch the object [N].
        open_time: duration of OpenGripper [s].
        grasp_candidates: grasps tried per object (best first).
        spot_samples: candidate destinations sampled per object.
        spot_margin: free space between the placed object and its neighbours [m].
        part_margin: placed centre at least this far inside the destination part [m].
        relation_gap: extra distance beyond the relation margin for place_relative [m].
        rrt_iterations: RRT-Connect budget per joint-space move.
        order: the order in which a task's moved objects are picked, one of :data:`PICK_ORDERS`:
            ``instruction`` (as the task lists them) or ``nearest`` (SAMPLE-HD's: the remaining object
            nearest the effector at each approach's start, see :mod:`samplehd.motion.order`).
    """

    approach_distance: float = bounded(0.08, lo=0.0, unit="m")
    retreat_distance: float = bounded(0.08, lo=0.0, unit="m")
    transport_clearance: float = bounded(0.04, lo=0.0, unit="m")
    min_lift: float = bounded(0.1, lo=0.0, unit="m")
    min_transport_height: float = bounded(0.18, lo=0.0, unit="m")
    approach_speed: float = bounded(0.1, lo=0.0, lo_open=True, unit="m/s")
    lift_speed: float = bounded(0.12, lo=0.0, lo_open=True, unit="m/s")
    joint_speed: float = bounded(1.2, lo=0.0, lo_open=True, unit="rad/s")
    joint_ramp_time: float = bounded(0.6, lo=0.0, unit="s")
    line_ramp_time: float = bounded(0.5, lo=0.0, unit="s")
    max_tcp_speed: float = bounded(0.245, lo=0.0, lo_open=True, unit="m/s")
    max_tcp_angular_speed: float = bounded(0.98, lo=0.0, lo_open=True, unit="rad/s")
    finger_clearance: float = bounded(0.0015, lo=0.0, unit="m")
    release_gap: float = bounded(0.006, lo=0.0, unit="m")
    max_drop: float = bounded(0.08, lo=0.0, unit="m")
    max_drop_into: float = bounded(0.15, lo=0.0, unit="m")
    close_time: float = bounded(1.0, lo=0.0, lo_open=True, unit="s")
    grip_settle_time: float = bounded(0.2, lo=0.0, unit="s")
    squeeze_force: float = bounded(20.0, lo=0.0, lo_open=True, unit="N")
    open_time: float = bounded(0.5, lo=0.0, lo_open=True, unit="s")
    grasp_candidates: int = bounded(8, lo=1)
    spot_samples: int = bounded(400, lo=1)
    spot_margin: float = bounded(0.02, lo=0.0, unit="m")
    part_margin: float = bounded(0.03, lo=0.0, unit="m")
    relation_gap: float = bounded(0.03, lo=0.0, unit="m")
    rrt_iterations: int = bounded(1500, lo=1)
    order: str = bounded("instruction", choices=PICK_ORDERS)
