"""The generate configs the baseline recipes ship (scripts/baselines/*.json) load as `samplehd generate
--preset small --config FILE` reads them: a recipe never fails hours in on a config it could not read."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from samplehd.dataset.config import GenerateConfig, preset_config

CONFIGS = sorted((Path(__file__).resolve().parents[1] / "scripts" / "baselines").glob("*.json"))


@pytest.mark.parametrize("path", CONFIGS, ids=[p.name for p in CONFIGS])
def test_a_recipe_config_loads(path: Path) -> None:
    config = GenerateConfig.from_dict(json.loads(path.read_text()), base=preset_config("small"))
    assert config.num_scenes >= 1


def test_the_stack_three_scenes_hold_what_a_three_object_stack_needs() -> None:
    config = GenerateConfig.from_dict(json.loads((CONFIGS[0].parent / "keypose_stack_three.json").read_text()),
                                      base=preset_config("small"))
    assert config.instructions.families == ("stack_three",)
    assert {"plate", "chopping_board"} <= set(config.scene.classes)  # a middle and a bottom
