"""Procedural geometry: real-world dimensions, collision pieces, caching, speed, determinism."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from samplehd.catalogue import ObjectInstance, build_geometry, load_catalogue, object_facts
from samplehd.catalogue.geometry import _build_base, _build_scaled

# The procedural catalogue's own shapes (shop-vrb's are tested in test_shop_vrb.py).
PROCEDURAL = "procedural"


def _all_variants():
    cat = load_catalogue(name=PROCEDURAL)
    return [(c.name, v.name) for c in cat.classes.values() for v in c.variants.values()]


def _instance(cls: str, variant: str, size: str = "medium") -> ObjectInstance:
    menu = load_catalogue(name=PROCEDURAL).classes[cls].variants[variant].menu
    colour, material = menu.pairs[0]
    return ObjectInstance(cls, variant, colour, material, size)


@pytest.mark.parametrize(
    ("cls", "variant", "axis", "lo", "hi"),
    [
        ("mug", "straight", 2, 0.09, 0.10),  # height ~9.5 cm
        ("mug", "straight", 1, 0.075, 0.085),  # diameter ~8 cm (handle along x)
        ("plate", "dinner", 0, 0.25, 0.27),  # ~26 cm
        ("soda_can", "standard", 2, 0.115, 0.125),
        ("wine_glass", "red", 2, 0.18, 0.23),
        ("fork", "dinner", 0, 0.18, 0.21),
        ("chopping_board", "rectangular", 0, 0.3, 0.4),
        ("pan", "frying", 1, 0.24, 0.28),
    ],
)
def test_real_world_dimensions(cls: str, variant: str, axis: int, lo: float, hi: float) -> None:
    ext = object_facts(_instance(cls, variant)).extents
    assert lo <= ext[axis] <= hi, ext


def test_sizes_scale_uniformly() -> None:
    small = object_facts(_instance("bowl", "round", "small"))
    large = object_facts(_instance("bowl", "round", "large"))
    ratio = np.array(large.extents) / np.array(small.extents)
    np.testing.assert_allclose(ratio, 1.2 / 0.8, rtol=1e-5)
    assert large.mass / small.mass == pytest.approx((1.2 / 0.8) ** 3, rel=1e-3)


@pytest.mark.parametrize(("cls", "variant"), _all_variants())
def test_geometry_is_consistent(cls: str, variant: str) -> None:
    inst = _instance(cls, variant)
    facts = object_facts(inst)
    g = build_geometry(load_catalogue(name=PROCEDURAL).classes[cls].variants[variant].geometry)
    assert g.vertices.shape[1] == 3 and g.faces.shape[1] == 3 and len(g.texcoords) == len(g.vertices)
    assert g.faces.max() < len(g.vertices)
    assert abs(facts.bbox_min[2]) < 1e-6, "objects rest on z = 0"
    assert g.volume > 0 and g.area > 0
    assert all(p.volume > 0 for p in g.pieces)
    # the collision pieces cover the visual mesh's bounding box (within 1 cm)
    pts = np.vstack([p.vertices for p in g.pieces if p.kind == "mesh"] or [np.zeros((1, 3))])
    for p in g.pieces:
        if p.kind == "box":
            w, x, y, z = p.quat
            rot = Rotation.from_quat([x, y, z, w]).as_matrix()
            signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)])
            pts = np.vstack([pts, np.array(p.pos) + (signs * np.array(p.half_extents)) @ rot.T])
    lo, hi = g.vertices.min(0), g.vertices.max(0)
    assert np.all(pts.min(0) <= lo + 0.01) and np.all(pts.max(0) >= hi - 0.01)
    # footprint polygon is counter-clockwise and inside the bounding box
    poly = np.array(facts.footprint_polygon)
    signed = 0.5 * np.sum(poly[:, 0] * np.roll(poly[:, 1], -1) - poly[:, 1] * np.roll(poly[:, 0], -1))
    assert signed > 0
    assert facts.footprint_radius >= max(facts.footprint_half_extents) - 1e-9
    assert facts.grasps, "every object has a grasp hint"
    if facts.affordances.container:
        assert facts.opening is not None and facts.opening.radius > 0.01 and facts.opening.depth > 0.01
    if facts.affordances.handle_pickable:
        assert any(s.name == "handle" for s in facts.grasps)


def test_containers_have_walls_made_of_sector_pieces() -> None:
    g = build_geometry(load_catalogue(name=PROCEDURAL).classes["bowl"].variants["round"].geometry)
    assert len(g.pieces) >= 12  # a bottom plus convex wall segments around the axis
    # no piece covers the axis above the floor: something can go into the bowl
    floor = object_facts(_instance("bowl", "round")).opening.floor_height
    for p in g.pieces:
        above = p.vertices[p.vertices[:, 2] > floor + 1e-6]
        if len(above):
            assert np.min(np.linalg.norm(above[:, :2], axis=1)) > 0.03


def test_geometry_of_every_class_builds_and_is_cached() -> None:
    cat = load_catalogue(name=PROCEDURAL)
    _build_base.cache_clear()
    _build_scaled.cache_clear()
    for cls in cat.classes.values():
        for v in cls.variants.values():
            for s in cat.sizes.values():
                mesh = build_geometry(v.geometry, s.scale)
                assert len(mesh.faces) > 0
    g = cat.classes["mug"].variants["straight"].geometry
    assert build_geometry(g, 1.2) is build_geometry(g, 1.2)


def test_geometry_is_deterministic() -> None:
    spec = load_catalogue(name=PROCEDURAL).classes["wine_glass"].variants["red"].geometry
    a = build_geometry(spec)
    _build_base.cache_clear()
    _build_scaled.cache_clear()
    b = build_geometry(spec)
    assert a is not b
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)
    for p, q in zip(a.pieces, b.pieces, strict=True):
        np.testing.assert_array_equal(p.vertices, q.vertices)


def test_geometry_arrays_are_read_only() -> None:
    g = build_geometry(load_catalogue(name=PROCEDURAL).classes["mug"].variants["straight"].geometry)
    with pytest.raises(ValueError):
        g.vertices[0, 0] = 1.0
