"""Grasp registry: candidates per site kind, clearance filtering, poses, serialisation."""

from __future__ import annotations

import numpy as np

from samplehd.robot.constants import GRIPPER_STROKE
from samplehd.world.grasps import MIN_CLEARANCE, Grasp, grasp_candidates


class Site:
    def __init__(self, name, position, approach, closing, width, axisymmetric=False):
        self.name, self.position, self.approach, self.closing = name, position, approach, closing
        self.width, self.axisymmetric = width, axisymmetric


BOX = (np.array([-0.05, -0.03, 0.0]), np.array([0.05, 0.03, 0.1]))


def test_axisymmetric_body_gets_yaws_and_handles_come_last():
    sites = [Site("handle", (0.06, 0, 0.05), (0, 0, -1), (0, 1, 0), 0.011),
             Site("body", (0, 0, 0.06), (0, 0, -1), (0, 1, 0), 0.07, True)]
    cands = grasp_candidates(sites, *BOX)
    names = [g.name for g in cands]
    assert names[:8] == ["body"] * 8 and names[-1] == "handle"
    closings = np.array([g.closing for g in cands if g.name == "body"])
    assert len({tuple(np.round(c, 6)) for c in closings}) == 8  # eight distinct yaws
    for g in cands:
        assert g.width + 2 * MIN_CLEARANCE <= g.opening + 1e-12 <= GRIPPER_STROKE + 1e-12


def test_too_wide_sites_are_dropped_and_side_sites_become_top_down():
    wide = Site("body", (0, 0, 0.05), (0, 0, -1), (0, 1, 0), 0.09)
    side = Site("body", (0, 0, 0.05), (-1, 0, 0), (0, 1, 0), 0.06, True)
    cands = grasp_candidates([wide, side], *BOX)
    assert cands and all(g.approach[2] == -1.0 for g in cands)
    assert all(g.width == 0.06 for g in cands)


def test_no_sites_falls_back_to_the_bounding_box():
    cands = grasp_candidates([], *BOX)
    assert cands and all(g.name == "box" for g in cands)
    assert min(g.width for g in cands) == 0.06  # across the narrow side


def test_pose_maps_the_finger_axis_onto_the_closing_direction():
    g = Grasp("body", (0.0, 0.0, 0.05), (0.0, 0.0, -1.0), (0.6, 0.8, 0.0), 0.05, 0.07)
    finger_axis = np.array([0.0, -1.0, 0.0])
    r = g.rotation(finger_axis)
    assert np.allclose(r @ r.T, np.eye(3)) and np.isclose(np.linalg.det(r), 1.0)
    assert np.allclose(r @ finger_axis, (0.6, 0.8, 0.0))
    assert np.allclose(r[:, 2], (0.0, 0.0, -1.0))
    assert Grasp.from_dict(g.to_dict()) == g
