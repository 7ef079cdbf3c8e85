"""Materials a perception model is asked to name must be visible in the GL images it learns from."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from samplehd.catalogue.instance import ObjectInstance
from samplehd.render.renderer import SceneRenderer
from samplehd.scene.sampler import SCENE_CAMERA
from samplehd.scene.spec import SceneObject, SceneSpec, compile_scene
from samplehd.scene.world import OPERATOR_CAMERA, CameraSpec
from samplehd.world.layout import LAYOUT


def _pixels(cls: str, variant: str, material: str) -> np.ndarray:
    """The object's pixels (sorted by brightness) of one object at the middle of the table, seen by the
    default scene camera at 640x360 (fast preset)."""
    camera = CameraSpec(SCENE_CAMERA, OPERATOR_CAMERA.pos, OPERATOR_CAMERA.target, OPERATOR_CAMERA.fovy)
    obj = SceneObject(ObjectInstance(cls, variant, "blue", material, "medium"),
                      (0.0, 0.0, LAYOUT.table_height + 0.0005), (0.966, 0.0, 0.0, 0.259))
    model, data = compile_scene(SceneSpec(0, 0, (obj,), camera))
    with SceneRenderer(model, 640, 360, "fast") as r:
        img = r.render(data, SCENE_CAMERA, ("rgb", "segmentation"))
    px = img["rgb"][img["segmentation"] >= 3].astype(float)
    return px


def _look(px: np.ndarray) -> np.ndarray:
    """Brightness percentiles and the mean step between neighbouring pixels' brightness: what tells a
    highlight, a streak or a matte grain."""
    v = px.max(axis=1)
    return np.array([*np.percentile(v, (10, 50, 90, 99)), np.abs(np.diff(v)).mean()])


@pytest.mark.parametrize(("cls", "variant"), [("plate", "dinner"), ("bowl", "round")])
def test_metal_plastic_ceramic_rubber_of_one_colour_look_different(cls: str, variant: str) -> None:
    looks = {m: _look(_pixels(cls, variant, m)) for m in ("metal", "plastic", "ceramic", "rubber")}
    for a, b in itertools.combinations(looks, 2):
        # some brightness percentile differs by 12 levels of 255 or more, or the texture does
        diff = np.abs(looks[a] - looks[b])
        assert diff[:4].max() >= 12 or diff[4] >= 3, (a, b, looks[a].round(1), looks[b].round(1))
