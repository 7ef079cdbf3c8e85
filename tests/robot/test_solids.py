"""Meshes of boxes and cylinders: closed, wound outwards, normals agreeing with the winding."""

from __future__ import annotations

import math

import numpy as np
import pytest

from samplehd.robot.solids import SolidMesh


def _enclosed_volume(mesh: SolidMesh) -> float:
    """Signed volume by the divergence theorem: positive only when every face winds outwards."""
    v = mesh.vertices[mesh.faces]
    return float(np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() / 6.0)


def test_box_and_cylinder_enclose_their_volume_and_wind_outwards() -> None:
    turned = [math.cos(0.3), 0.2, math.sin(0.3), 0.1]
    turned = list(np.divide(turned, np.linalg.norm(turned)))
    box, cylinder = SolidMesh(), SolidMesh()
    box.box((0.01, 0.02, 0.03), pos=(0.1, -0.2, 0.3), quat=turned)
    cylinder.cylinder(0.02, 0.05, pos=(0.1, -0.2, 0.3), quat=turned, segments=16)
    assert _enclosed_volume(box) == pytest.approx(8 * 0.01 * 0.02 * 0.03, rel=1e-9)
    # a 16-gon of circumradius r has area 8 r² sin(2π/16)
    assert _enclosed_volume(cylinder) == pytest.approx(8 * 0.02**2 * math.sin(math.pi / 8) * 0.1, rel=1e-9)
    for mesh in (box, cylinder):
        v, f, n = mesh.vertices, mesh.faces, mesh.normals
        winding = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        for corner in range(3):
            assert (np.einsum("ij,ij->i", winding, n[f[:, corner]]) > 0).all()
        np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0)


def test_merged_shapes_keep_their_own_vertices() -> None:
    mesh = SolidMesh()
    mesh.box((0.01, 0.01, 0.01), pos=(0, 0, 0))
    mesh.cylinder(0.01, 0.01, pos=(0, 0, 0.1), segments=12)
    assert len(mesh.faces) == 12 + 4 * 12
    assert mesh.faces.max() == len(mesh.vertices) - 1
    assert mesh.faces[12:].min() == 24  # the cylinder's faces index its own vertices, after the box's 24
