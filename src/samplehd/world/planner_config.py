"""The planner's distances, speeds and search budgets, shared by the feasibility queries (grasps, free
spots) that scenes and instructions ask and by the subtask planner itself."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from samplehd.errors import ConfigError

__all__ = ["PlannerConfig"]


@dataclass(frozen=True)
class PlannerConfig:
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
    """

    approach_distance: float = 0.08
    retreat_distance: float = 0.08
    transport_clearance: float = 0.04
    min_lift: float = 0.1
    min_transport_height: float = 0.18
    approach_speed: float = 0.1
    lift_speed: float = 0.12
    joint_speed: float = 1.2
    joint_ramp_time: float = 0.6
    line_ramp_time: float = 0.5
    max_tcp_speed: float = 0.245
    max_tcp_angular_speed: float = 0.98
    finger_clearance: float = 0.0015
    release_gap: float = 0.006
    max_drop: float = 0.08
    close_time: float = 1.0
    grip_settle_time: float = 0.2
    squeeze_force: float = 20.0
    open_time: float = 0.5
    grasp_candidates: int = 8
    spot_samples: int = 400
    spot_margin: float = 0.02
    part_margin: float = 0.03
    relation_gap: float = 0.03
    rrt_iterations: int = 1500

    def __post_init__(self) -> None:
        for k, v in asdict(self).items():
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ConfigError(f"planner.{k}={v!r} must be a finite non-negative number")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PlannerConfig:
        unknown = set(d) - set(cls.__dataclass_fields__)
        if unknown:
            raise ConfigError(f"unknown planner options {sorted(unknown)}; valid: {sorted(cls.__dataclass_fields__)}")
        return cls(**d)
