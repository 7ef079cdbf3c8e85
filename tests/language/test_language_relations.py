"""compute_relationships: CLEVR-style relations from positions."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from samplehd.fixedmath import dot
from samplehd.world.layout import DIRECTIONS
from samplehd.world.relations import RELATIONS, compute_relationships


def test_simple_layout_from_the_operator_viewpoint() -> None:
    # object 0 at the centre, 1 to its left (-y), 2 in front of it (+x)
    objects = [{"3d_coords": [0.0, 0.0, 0.8]}, {"3d_coords": [0.0, -0.2, 0.8]}, {"3d_coords": [0.2, 0.0, 0.8]}]
    rel = compute_relationships(objects, DIRECTIONS, margin=0.02)
    assert rel["left"][0] == [1]
    assert rel["right"][1] == [0, 2]
    assert rel["front"][0] == [2]
    assert rel["behind"][2] == [0, 1]
    assert set(rel) == set(RELATIONS)


def test_margin_excludes_near_ties() -> None:
    objects = np.array([[0.0, 0.0, 0.0], [0.0, -0.01, 0.0]])
    assert compute_relationships(objects, margin=0.02)["left"][0] == []
    assert compute_relationships(objects, margin=0.0)["left"][0] == [1]


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1)), min_size=0, max_size=12), st.floats(0, 0.1))
def test_matches_pairwise_definition(points: list[tuple[float, float]], margin: float) -> None:
    coords = np.array([[x, y, 0.0] for x, y in points]).reshape(-1, 3)
    rel = compute_relationships(coords, DIRECTIONS, margin)
    for name in RELATIONS:
        d = np.array(DIRECTIONS[name])
        for i in range(len(coords)):
            expected = [j for j in range(len(coords)) if j != i and dot(coords[j] - coords[i], d) > margin]
            assert rel[name][i] == expected
