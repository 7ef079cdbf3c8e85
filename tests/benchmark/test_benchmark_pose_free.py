"""The suite draw's pose-free test: a scene it passes over has no task of the family, wherever its objects stand."""

from __future__ import annotations

import numpy as np
import pytest

from samplehd.benchmark.levels import pose_free_objects
from samplehd.benchmark.suite import scene_seeds
from samplehd.envs.episodes import SceneCache
from samplehd.language.generator import POSE_FREE_CONSTRAINTS, generate_instructions, may_have_family
from samplehd.language.scene import parse_scene
from samplehd.language.templates import default_templates
from samplehd.scene.config import SceneConfig
from samplehd.tasks.task import family_names

pytestmark = pytest.mark.render  # scenes are sampled (occlusion renders)

FIELDS = ("name", "colour", "material", "size", "extents", "handle_pickable", "container", "stackable_on",
          "stackable", "opening_radius", "top_extent")


@pytest.fixture(scope="module", params=["procedural", "shop-vrb"])
def scenes(request):
    cache = SceneCache(SceneConfig(catalogue=request.param, min_objects=3, max_objects=6), size=24, gl_free=False)
    return cache, [cache.scene(s) for s in scene_seeds(7, 0, 24)]


def test_pose_free_objects_are_the_annotations_objects_without_their_poses(scenes):
    cache, sampled = scenes
    for scene in sampled:
        annotated = parse_scene(cache.annotation(scene)).objects
        for mine, theirs in zip(pose_free_objects(scene, cache), annotated, strict=True):
            assert {f: getattr(mine, f) for f in FIELDS} == {f: getattr(theirs, f) for f in FIELDS}
            assert mine.graspable >= theirs.graspable  # the class may be; the scene decides


def test_a_family_it_rules_out_has_no_instruction_on_the_scene(scenes):
    cache, sampled = scenes
    ruled_out = 0
    for scene in sampled:
        objects = pose_free_objects(scene, cache)
        annotation = cache.annotation(scene)
        for family in family_names():
            if may_have_family(objects, family):
                continue
            ruled_out += 1
            for r in range(4):
                made = generate_instructions(annotation, np.random.default_rng([scene.seed, r]), per_scene=16,
                                             families=[family]).instructions
                assert not made, (scene.seed, family)
    assert ruled_out > 10  # stack_three on most scenes of 3-6 objects, put or stack on some


def test_families_without_pose_free_constraints_are_always_possible():
    free = {t.family for t in default_templates() if not any(c.type in POSE_FREE_CONSTRAINTS for c in t.constraints)}
    assert {"pick_up", "place"} <= free
    for family in free:
        assert may_have_family([], family)
    assert not may_have_family([], "stack_three")
