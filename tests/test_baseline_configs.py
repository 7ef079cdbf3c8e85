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


@pytest.mark.parametrize("name", ["keypose_stack_three.json", "keypose_stack_three_tops.json"])
def test_the_stack_three_scenes_hold_what_a_three_object_stack_needs(name: str) -> None:
    config = GenerateConfig.from_dict(json.loads((CONFIGS[0].parent / name).read_text()),
                                      base=preset_config("small"))
    assert config.instructions.families == ("stack_three",)
    assert {"plate", "chopping_board"} <= set(config.scene.classes)  # a middle and a bottom


def test_the_two_stack_three_datasets_put_every_top_of_the_suite_on_a_stack() -> None:
    """Between them, the two stack_three datasets stack each class `core`'s SHOP-VRB stack_three
    episodes put on top (bowl, glass, mug, soda can, thermos), on scenes of their own seeds."""
    configs = [GenerateConfig.from_dict(json.loads((CONFIGS[0].parent / name).read_text()),
                                        base=preset_config("small"))
               for name in ("keypose_stack_three.json", "keypose_stack_three_tops.json")]
    tops = {"bowl", "glass", "mug", "soda_can", "thermos"}
    assert tops <= set(configs[0].scene.classes) | set(configs[1].scene.classes)
    assert configs[0].seed != configs[1].seed
