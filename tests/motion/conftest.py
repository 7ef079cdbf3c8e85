"""A hand-placed scene shared by the path tests: four objects of different classes, materials and shapes
within the arm's reach."""

from __future__ import annotations

import pytest

TABLE = 0.75  # [m] table top height
UP = (1.0, 0.0, 0.0, 0.0)


@pytest.fixture(scope="module")
def scene():
    from samplehd.catalogue import ObjectInstance
    from samplehd.scene.spec import SceneObject, SceneSpec

    objs = (
        SceneObject(ObjectInstance("food_box", "flat", "red", "plastic", "medium"), (0.02, -0.25, TABLE), UP),
        SceneObject(ObjectInstance("soda_can", "standard", "red", "metal", "medium"), (0.05, 0.12, TABLE), UP),
        SceneObject(ObjectInstance("bowl", "round", "white", "ceramic", "medium"), (0.20, -0.05, TABLE), UP),
        SceneObject(ObjectInstance("glass", "short", "transparent", "glass", "medium"), (-0.08, -0.05, TABLE), UP),
    )
    return SceneSpec(index=7, seed=0, objects=objs)
