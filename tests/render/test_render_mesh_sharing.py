"""One GL context across the segmentation renders of many scenes: the same images as a context per model."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from samplehd.errors import RenderError
from samplehd.render.image_spec import ImageSpec
from samplehd.render.renderer import SceneRenderer
from samplehd.render.renderer_cache import MeshSharingRenderers, mesh_signatures
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import _visible_pixels, sample_scene
from samplehd.scene.spec import compile_scene
from samplehd.scene.world import SCENE_CAMERA

pytestmark = pytest.mark.render

SEGMENTATION = ImageSpec(320, 180, "fast", (SCENE_CAMERA,), ("segmentation",))


def _scenes() -> list:
    """Scenes of both catalogues with 3 to 8 objects, so that the number of meshes grows and shrinks."""
    out = []
    for seed, (catalogue, low, high) in enumerate([("shop-vrb", 3, 4), ("shop-vrb", 7, 8), ("procedural", 3, 3),
                                                   ("shop-vrb", 5, 6), ("procedural", 7, 8), ("shop-vrb", 3, 3)]):
        config = SceneConfig(catalogue=catalogue, min_objects=low, max_objects=high)
        out.append((sample_scene(0, 900 + seed, config).scene, config))
    return out


def _own_segmentation(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    with SceneRenderer(model, SEGMENTATION.width, SEGMENTATION.height, "fast") as r:
        return r.render(data, SCENE_CAMERA, ("segmentation",))["segmentation"].copy()


def test_shared_context_draws_what_a_context_of_the_models_own_draws():
    scenes = _scenes()
    meshes = []
    renderers = MeshSharingRenderers()
    try:
        for scene, config in scenes:
            model, data = compile_scene(scene)
            meshes.append(model.nmesh)
            shared = renderers.get(model, SEGMENTATION).render(data, SCENE_CAMERA, ("segmentation",))
            assert np.array_equal(shared["segmentation"], _own_segmentation(model, data))
            # the occlusion check's counts, on both
            n = len(scene.objects)
            with_own = _visible_pixels(model, data, n, config, _Own())
            assert _visible_pixels(model, data, n, config, renderers) == with_own
    finally:
        renderers.close()
    assert len(set(meshes)) == len(meshes) and meshes != sorted(meshes)  # grew and shrank


class _Own:
    """A renderer of the model's own per request (what the sampler did before sharing)."""

    def get(self, model: mujoco.MjModel, image: ImageSpec) -> SceneRenderer:
        return SceneRenderer(model, image.width, image.height, image.preset)


def test_a_scene_sampled_with_shared_renderers_is_the_scene_sampled_with_its_own():
    from samplehd.render.renderer_cache import RendererCache

    config = SceneConfig(catalogue="shop-vrb", min_objects=5, max_objects=7)
    for seed in (11, 12, 13):
        shared = sample_scene(0, seed, config)  # the thread's mesh-sharing renderers
        with RendererCache() as own:
            mine = sample_scene(0, seed, config, renderers=own)
        assert shared.scene == mine.scene and shared.visible_pixels == mine.visible_pixels
        assert shared.rejections == mine.rejections


def test_mesh_signatures_tell_meshes_apart_and_the_arm_stays():
    (a, _), (b, _) = _scenes()[:2]
    sa, sb = (mesh_signatures(compile_scene(s)[0]) for s in (a, b))
    arm = next(i for i, (x, y) in enumerate(zip(sa, sb, strict=False)) if x != y)
    assert arm > 20  # the arm's and gripper's meshes come first and are the same in every scene
    assert len(set(sa)) > arm  # object meshes differ from the arm's


def test_only_segmentation_with_a_gl_preset():
    model, _ = compile_scene(_scenes()[0][0])
    renderers = MeshSharingRenderers()
    try:
        for image in (ImageSpec(320, 180, "fast", (SCENE_CAMERA,), ("rgb",)),
                      ImageSpec(320, 180, "photo", (SCENE_CAMERA,), ("segmentation",))):
            with pytest.raises(RenderError, match="segmentation with a GL preset only"):
                renderers.get(model, image)
    finally:
        renderers.close()
