"""The sampler's occlusion check: objects that cannot hide each other are drawn alone together, and
each one's pixel count is the one it has drawn alone."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from samplehd.render.image_spec import ImageSpec
from samplehd.render.renderer import SEG_OBJECT_OFFSET
from samplehd.render.renderer_cache import RendererCache
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import _alone_groups, _apart, _screen_bounds, _visible_pixels, sample_scene
from samplehd.scene.spec import compile_scene, object_qpos_addresses
from samplehd.scene.world import SCENE_CAMERA


def test_apart_needs_a_gap_on_one_axis():
    a = (0.0, 10.0, 0.0, 10.0)
    assert _apart(a, (10.5, 20.0, 0.0, 10.0))
    assert _apart(a, (0.0, 10.0, 11.0, 20.0))
    assert not _apart(a, (10.0, 20.0, 0.0, 10.0))  # a shared edge may share a pixel
    assert not _apart(a, (5.0, 6.0, 5.0, 6.0))
    assert not _apart(a, None) and not _apart(None, a)  # behind the camera: drawn on its own


def test_groups_are_first_fit_and_pairwise_apart():
    boxes = [(0.0, 10.0, 0.0, 10.0), (5.0, 15.0, 0.0, 10.0), (20.0, 30.0, 0.0, 10.0), None, (12.0, 18.0, 20.0, 30.0)]
    assert _alone_groups(boxes) == [[0, 2, 4], [1], [3]]


@pytest.mark.render
@pytest.mark.parametrize("catalogue", ["shop-vrb", "procedural"])
def test_alone_counts_are_those_of_one_render_per_object(catalogue):
    config = SceneConfig(catalogue=catalogue, min_objects=6, max_objects=7)
    scene = sample_scene(0, 4242, config).scene
    model, data = compile_scene(scene)
    n = len(scene.objects)
    w, h = config.occlusion_resolution
    groups = _alone_groups(_screen_bounds(model, data, n, w, h))
    assert len(groups) < n  # some objects share a render
    with RendererCache() as renderers:
        visible, alone = _visible_pixels(model, data, n, config, renderers)
        r = renderers.get(model, ImageSpec(w, h, "fast", (SCENE_CAMERA,), ("segmentation",)))
        adr = object_qpos_addresses(model, n)
        saved = data.qpos.copy()
        one_by_one = []
        for i in range(n):
            for j in range(n):
                if j != i:
                    data.qpos[adr[j] : adr[j] + 3] = (50.0 + j, 50.0, -50.0)
            mujoco.mj_kinematics(model, data)
            mujoco.mj_camlight(model, data)
            seg = r.render(data, SCENE_CAMERA, ("segmentation",))["segmentation"]
            one_by_one.append(int(np.count_nonzero(seg == SEG_OBJECT_OFFSET + i)))
            data.qpos[:] = saved
        mujoco.mj_forward(model, data)
        seg = r.render(data, SCENE_CAMERA, ("segmentation",))["segmentation"]
    assert alone == one_by_one
    assert visible == [int(np.count_nonzero(seg == SEG_OBJECT_OFFSET + i)) for i in range(n)]
    assert all(a >= v > 0 for a, v in zip(alone, visible, strict=True))
