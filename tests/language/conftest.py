"""Fixtures for the language tests: seeded synthetic scenes and instructions generated for them."""

from __future__ import annotations

import numpy as np
import pytest

from samplehd.language.generator import GenerationResult, TemplateBalancer, generate_instructions
from samplehd.language.scene import Scene, parse_scene
from samplehd.language.synthetic import synthetic_scene


@pytest.fixture(scope="session")
def scene_dicts() -> list[dict]:
    """120 synthetic scenes of 2 to 8 objects."""
    rng = np.random.default_rng(1234)
    return [synthetic_scene(rng, int(rng.integers(2, 9)), image_index=i) for i in range(120)]


@pytest.fixture(scope="session")
def scenes(scene_dicts: list[dict]) -> list[Scene]:
    """The synthetic scenes, parsed."""
    return [parse_scene(s) for s in scene_dicts]


@pytest.fixture(scope="session")
def generated(scenes: list[Scene]) -> list[tuple[Scene, GenerationResult]]:
    """Instructions for every synthetic scene (families balanced)."""
    balancer = TemplateBalancer("families")
    out = []
    for k, scene in enumerate(scenes):
        rng = np.random.default_rng([7, k])
        result = generate_instructions(scene, rng, per_scene=6, balance="families", balancer=balancer)
        out.append((scene, result))
    return out
