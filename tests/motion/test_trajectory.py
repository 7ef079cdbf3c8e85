"""Timing of joint moves and straight lines: speed limits, smooth starts and stops, exact ends."""

from __future__ import annotations

import numpy as np
import pytest

from samplehd.fixedmath import matmul
from samplehd.motion.trajectory import _axis_angle, _interpolate, cruise_profile, interpolate_pose, joint_path, min_jerk

DT = 0.05


def _speeds(s: np.ndarray, dist: float) -> np.ndarray:
    return np.diff(np.r_[0.0, s, s[-1]]) * dist / DT


@pytest.mark.parametrize("dist", [0.01, 0.1, 0.3, 0.8, 2.0])
def test_cruise_profile_respects_the_speed_limit_and_ends_exactly(dist: float) -> None:
    s = cruise_profile(dist, 0.22, DT)
    assert s[-1] == 1.0
    assert np.all(np.diff(s) >= 0)
    v = _speeds(s, dist)
    assert v.max() <= 0.22 + 1e-9
    # smooth: it starts and stops slowly, and the speed changes by a bounded amount per step
    assert v[0] < 0.1 * 0.22 and v[-2] < 0.1 * 0.22
    if dist >= 0.3:  # cruising: the ramps' peak acceleration is 1.5 vmax / ramp_time
        assert np.abs(np.diff(v)).max() <= 1.5 * 0.22 / 0.6 * DT + 1e-9


def test_long_moves_cruise_and_are_quicker_than_minimum_jerk() -> None:
    dist, vmax = 0.8, 0.22
    s = cruise_profile(dist, vmax, DT)
    n_min_jerk = int(np.ceil(1.875 * dist / vmax / DT))
    assert len(s) < 0.75 * n_min_jerk
    v = _speeds(s, dist)
    assert np.sum(v > 0.95 * vmax) > len(s) / 2  # most of the move at the limit


def test_short_moves_and_zero_ramp_stay_minimum_jerk() -> None:
    np.testing.assert_allclose(cruise_profile(0.05, 0.22, DT), min_jerk(int(np.ceil(1.875 * 0.05 / 0.22 / DT))))
    np.testing.assert_allclose(cruise_profile(1.0, 0.22, DT, ramp_time=0.0), min_jerk(int(np.ceil(1.875 / 0.22 / DT))))
    assert len(cruise_profile(0.001, 0.22, DT, min_time=0.3)) == 6  # at least min_time


def test_joint_path_ends_at_every_waypoint_within_the_joint_speed() -> None:
    wps = np.array([[0.0] * 6, [1.5, -0.5, 0.2, 0.0, 0.0, 0.0], [1.5, -0.5, 0.2, 0.0, 0.0, 0.8]])
    path = joint_path(wps, DT, 1.2)
    np.testing.assert_allclose(path[-1], wps[-1])
    steps = np.abs(np.diff(np.vstack([wps[0], path]), axis=0)).max(axis=1) / DT
    assert steps.max() <= 1.2 + 1e-9
    # it stops at the middle waypoint
    k = int(np.argmin(np.linalg.norm(path - wps[1], axis=1)))
    np.testing.assert_allclose(path[k], wps[1], atol=1e-12)


@pytest.mark.parametrize("field", ["joint_ramp_time", "line_ramp_time", "grip_settle_time", "approach_speed"])
@pytest.mark.parametrize("value", [-0.1, float("nan"), "fast"])
def test_bad_planner_timing_is_a_one_line_error(field: str, value: object) -> None:
    from samplehd.errors import ConfigError
    from samplehd.world.planner_config import PlannerConfig

    with pytest.raises(ConfigError, match=rf"^paths\.planner\.{field}=.*: must be a finite number [>≥] 0 "):
        PlannerConfig.from_dict({field: value})


def test_unknown_planner_option_names_the_valid_ones() -> None:
    from samplehd.errors import ConfigError
    from samplehd.world.planner_config import PlannerConfig

    with pytest.raises(ConfigError, match=r"paths.planner: unknown option\(s\) \['ramp'\]; valid: .*joint_ramp_time"):
        PlannerConfig.from_dict({"ramp": 0.5})


def test_a_lines_poses_share_its_turn_bit_for_bit() -> None:
    """cartesian_path computes the line's rotation once; each pose is interpolate_pose's, bit for bit."""
    rng = np.random.default_rng(5)
    for _ in range(20):
        poses = []
        for _ in range(2):
            q = rng.normal(size=4)
            w, x, y, z = q / np.linalg.norm(q)
            t = np.eye(4)
            t[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
            t[:3, 3] = rng.normal(0.0, 0.3, 3)
            poses.append(t)
        a, b = poses
        turn = _axis_angle(matmul(a[:3, :3].T, b[:3, :3]))
        for s in min_jerk(17):
            assert np.array_equal(_interpolate(a, b, turn, float(s)), interpolate_pose(a, b, float(s)))
