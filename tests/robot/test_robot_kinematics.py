"""Analytic UR5e kinematics: FK against MuJoCo, FK∘IK = identity, all 8 branches, errors."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from robot_world import BASE_POS, build_table_world

from samplehd.errors import KinematicsError, UnreachableError
from samplehd.robot.constants import HOME_QPOS, JOINT_LIMITS, JOINT_NAMES, TCP_OFFSET
from samplehd.robot.kinematics import (
    fk_flange,
    fk_tcp,
    forward_kinematics,
    ik_all,
    ik_batch,
    ik_flange,
    ik_tcp,
    inverse_kinematics,
    pos_quat_from_pose,
    pose_from_pos_quat,
    wrap_to_limits,
)

_angles = st.lists(st.floats(-np.pi, np.pi, allow_nan=False), min_size=6, max_size=6).map(np.array)


def _base_transform(pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
    return pose_from_pos_quat(pos, quat)


@pytest.mark.parametrize("base_quat", [np.array([1.0, 0, 0, 0]), np.array([0.7071068, 0, 0, 0.7071068])])
def test_fk_equals_mujoco_site_poses(base_quat: np.ndarray) -> None:
    model = build_table_world(base_quat=base_quat).compile()
    data = mujoco.MjData(model)
    qadr = [model.jnt_qposadr[model.joint(j).id] for j in JOINT_NAMES]
    base = _base_transform(BASE_POS, base_quat)
    rng = np.random.default_rng(7)
    for _ in range(50):
        q = rng.uniform(JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1])
        data.qpos[qadr] = q
        mujoco.mj_kinematics(model, data)
        for site, fk in (("flange", fk_flange), ("tcp", fk_tcp)):
            expected = base @ fk(q)
            np.testing.assert_allclose(data.site(site).xpos, expected[:3, 3], atol=1e-9)
            np.testing.assert_allclose(data.site(site).xmat.reshape(3, 3), expected[:3, :3], atol=1e-9)


def test_fk_batches_and_tool_offset() -> None:
    rng = np.random.default_rng(1)
    q = rng.uniform(-3, 3, (5, 4, 6))
    poses = forward_kinematics(q)
    assert poses.shape == (5, 4, 4, 4)
    np.testing.assert_allclose(poses[2, 3], fk_flange(q[2, 3]))
    tcp = fk_tcp(q[0, 0])
    flange = fk_flange(q[0, 0])
    np.testing.assert_allclose(tcp[:3, 3], flange[:3, 3] + TCP_OFFSET * flange[:3, 2])


@settings(max_examples=300, deadline=None)
@given(q=_angles, seed=_angles)
def test_fk_of_ik_is_identity(q: np.ndarray, seed: np.ndarray) -> None:
    for offset in (0.0, TCP_OFFSET):
        pose = forward_kinematics(q, offset)
        sol = inverse_kinematics(pose, seed, offset)
        np.testing.assert_allclose(forward_kinematics(sol, offset), pose, atol=1e-6)
        assert np.all(sol >= JOINT_LIMITS[:, 0]) and np.all(sol <= JOINT_LIMITS[:, 1])


@settings(max_examples=200, deadline=None)
@given(q=_angles)
def test_ik_seeded_with_the_answer_returns_it(q: np.ndarray) -> None:
    # Joint angles are ill-conditioned at the stretched elbow and the wrist singularity (the
    # pose is still exact there, see test_fk_of_ik_is_identity); compare angles away from them.
    assume(abs(np.sin(q[2])) > 1e-3 and abs(np.sin(q[4])) > 1e-3)
    np.testing.assert_allclose(ik_tcp(fk_tcp(q), q), q, atol=1e-6)


def test_singular_wrist_and_stretched_elbow_are_solved() -> None:
    for q in ([0.0, 0.0, 0.0, -1.0, 0.0, -1.0], [0.5, -1.0, 0.3, -1.0, np.pi, -1.0], [0.25, 0, 0, 0, 0, 0]):
        pose = fk_flange(np.array(q))
        for seed in (np.array(q), np.zeros(6), HOME_QPOS):
            np.testing.assert_allclose(fk_flange(ik_flange(pose, seed)), pose, atol=1e-6)


def test_ik_all_returns_eight_exact_branches_for_a_generic_pose() -> None:
    pose = fk_tcp(HOME_QPOS)
    solutions = ik_all(pose, TCP_OFFSET)
    assert solutions.shape == (8, 6)
    assert len({tuple(np.round(s, 6)) for s in solutions}) == 8
    for s in solutions:
        np.testing.assert_allclose(fk_tcp(s), pose, atol=1e-9)


def test_ik_picks_the_solution_nearest_the_seed() -> None:
    pose = fk_tcp(HOME_QPOS)
    for target in ik_all(pose, TCP_OFFSET):
        if not (-np.pi <= target[2] <= np.pi):
            continue
        got = ik_tcp(pose, target + 0.05)
        np.testing.assert_allclose(got, target, atol=1e-7)


def test_ik_wraps_into_limits_towards_the_seed() -> None:
    seed = HOME_QPOS.copy()
    seed[0] -= 2 * np.pi  # same pose, other representation of the pan angle
    got = ik_tcp(fk_tcp(HOME_QPOS), seed)
    np.testing.assert_allclose(got, seed, atol=1e-7)


def test_batch_matches_single() -> None:
    rng = np.random.default_rng(3)
    q = rng.uniform(-np.pi, np.pi, (300, 6))
    seeds = rng.uniform(-np.pi, np.pi, (300, 6))
    poses = forward_kinematics(q, TCP_OFFSET)
    batch, ok = ik_batch(poses, seeds, TCP_OFFSET)
    assert ok.all()
    single = np.array([inverse_kinematics(p, s, TCP_OFFSET) for p, s in zip(poses, seeds, strict=True)])
    np.testing.assert_allclose(batch, single, atol=1e-8)


def test_a_batch_row_has_the_bits_of_its_own_call() -> None:
    """The grasp search solves several seeds of one pose in one ik_batch call: every row must be the
    bits of that row solved alone (small batches and the compiled products' sizes alike)."""
    rng = np.random.default_rng(11)
    for n in (2, 3, 4, 9, 17):
        poses = np.repeat(fk_tcp(rng.uniform(-np.pi, np.pi, 6))[None], n, axis=0)
        poses[n // 2:] = forward_kinematics(rng.uniform(-np.pi, np.pi, (n - n // 2, 6)), TCP_OFFSET)
        seeds = rng.uniform(-np.pi, np.pi, (n, 6))
        batch, ok = ik_batch(poses, seeds, TCP_OFFSET)
        for k in range(n):
            one, one_ok = ik_batch(poses[k:k + 1], seeds[k], TCP_OFFSET)
            assert batch[k].tobytes() == one[0].tobytes() and ok[k] == one_ok[0]
        wrapped, inside = wrap_to_limits(batch, seeds[0])
        for k in range(n):
            alone, alone_inside = wrap_to_limits(batch[k], seeds[0])
            assert wrapped[k].tobytes() == alone.tobytes() and inside[k] == alone_inside


@pytest.mark.parametrize(
    "position",
    [(2.0, 0.0, 0.3), (0.0, 0.0, 1.5), (0.0, 0.0, 0.4)],  # too far, too high, inside the base cylinder
)
def test_unreachable_poses_raise_one_line_error(position: tuple[float, float, float]) -> None:
    pose = np.eye(4)
    pose[:3, 3] = position
    with pytest.raises(UnreachableError) as err:
        ik_flange(pose, HOME_QPOS)
    assert "\n" not in str(err.value) and "reach" in str(err.value)
    assert ik_all(pose).shape == (0, 6)
    _, ok = ik_batch(pose[None], HOME_QPOS)
    assert not ok[0]


def test_bad_inputs_raise_kinematics_error() -> None:
    pose = fk_tcp(HOME_QPOS)
    bad = pose.copy()
    bad[0, 3] = np.nan
    cases = [
        lambda: ik_tcp(bad, HOME_QPOS),
        lambda: ik_tcp(pose[:3], HOME_QPOS),
        lambda: ik_tcp(pose, HOME_QPOS[:5]),
        lambda: ik_tcp(pose, np.full(6, np.nan)),
        lambda: ik_tcp(np.diag([2.0, 1.0, 1.0, 1.0]), HOME_QPOS),  # not a rotation
        lambda: fk_tcp(np.zeros(5)),
        lambda: fk_tcp(np.full(6, np.inf)),
        lambda: ik_batch(bad[None], HOME_QPOS),
    ]
    for case in cases:
        with pytest.raises(KinematicsError) as err:
            case()
        assert "\n" not in str(err.value)


def test_pose_quat_round_trip() -> None:
    pose = fk_tcp(HOME_QPOS + 0.3)
    pos, quat = pos_quat_from_pose(pose)
    np.testing.assert_allclose(pose_from_pos_quat(pos, quat), pose, atol=1e-12)


def test_docstring_examples_run() -> None:
    import doctest

    import samplehd.robot.controller
    import samplehd.robot.kinematics

    for module in (samplehd.robot.kinematics, samplehd.robot.controller):
        result = doctest.testmod(module)
        assert result.failed == 0
