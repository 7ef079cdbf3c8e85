"""A real, very small dataset with images for the learning tests (2 scenes, 1 pick_up each)."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("torch")

NANO = {
    "num_scenes": 2,
    "seed": 0,
    "test_every": 2,
    "scene": {"min_objects": 3, "max_objects": 3},
    "instructions": {"per_scene": 1, "families": ["pick_up"]},
    "render": {"mode": "fast", "width": 32, "height": 32, "cameras": ["scene", "wrist"], "modalities": ["rgb"]},
}


@pytest.fixture(scope="session")
def nano_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Scene 0 is a training scene, scene 1 a test scene; episodes carry 32×32 scene and wrist RGB."""
    from samplehd.dataset.config import GenerateConfig, preset_config
    from samplehd.dataset.generate import generate_dataset

    out = tmp_path_factory.mktemp("nano") / "ds"
    summary = generate_dataset(out, GenerateConfig.from_dict(NANO, base=preset_config("tiny")))
    assert summary.episodes >= 1
    return out
