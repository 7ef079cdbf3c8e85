"""One keypose policy for every task family: it trains on demonstrations of all seven, records what it
was trained on (families, words, the attribute values of its maps, never a held-out class), and acts
through ``samplehd evaluate`` on a family that moves several objects."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

FAMILIES = ["pick_up", "place", "place_relative", "put", "remove", "stack", "stack_three"]
EVERY_FAMILY = {
    "num_scenes": 3,
    "seed": 5,
    "test_every": 3,
    "scene": {"min_objects": 4, "max_objects": 4},
    "instructions": {"per_scene": 7, "balance": "families", "families": FAMILIES},
    "render": {"mode": "none", "width": 160, "height": 90},
}


@pytest.fixture(scope="module")
def every_family_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """States-only episodes of every family on the default (shop-vrb) shapes, 160×90 scene images."""
    from samplehd.dataset.config import GenerateConfig, preset_config
    from samplehd.dataset.generate import generate_dataset

    out = tmp_path_factory.mktemp("every_family") / "ds"
    generate_dataset(out, GenerateConfig.from_dict(EVERY_FAMILY, base=preset_config("small")))
    return out


@pytest.mark.slow
def test_one_keypose_policy_trains_on_every_family_and_acts(every_family_dataset: Path, tmp_path: Path) -> None:
    from samplehd.cli import main
    from samplehd.dataset.reader import DatasetReader
    from samplehd.language.levels import HELD_OUT_CLASSES
    from samplehd.learn.keypose.configuration import KeyposeConfig
    from samplehd.learn.keypose.exclusion import unknown_nouns

    reader = DatasetReader(every_family_dataset)
    moved = {reader.instruction(k)["family"] for k in range(len(reader.episodes))
             if reader.episode_meta(k).success}
    assert len(moved) >= 5, moved  # a tiny dataset: most families, each with its own decisions

    out = tmp_path / "all"
    assert main(["train", "policy", "--action", "keypose", "--dataset", str(every_family_dataset), "--out",
                 str(out), "--steps", "3", "--batch", "2", "--quiet"]) == 0
    config = json.loads((out / "config.json").read_text())
    metrics = json.loads((out / "metrics.json").read_text())
    assert len(config["families"]) >= 4 and set(config["families"]) <= set(FAMILIES)
    vocabulary = config["vocabulary"]
    assert {"pick", "the", "."} <= set(vocabulary["words"]) and vocabulary["name"]
    assert not HELD_OUT_CLASSES & set(vocabulary["name"])  # the maps never learn a held-out class
    # the sizes each class was seen with: of the classes the maps name, each range ordered
    shapes = KeyposeConfig.from_dict(config).vocabulary.shapes
    assert shapes and {r.name for r in shapes} <= set(vocabulary["name"])
    assert all(0 < lo <= hi for r in shapes for lo, hi in zip(r.low, r.high, strict=True))
    assert metrics["train_decisions"] > metrics["train_episodes"]  # families that move several objects

    report = tmp_path / "report.json"
    assert main(["evaluate", "--policy", "bc", "--models", str(out), "--families", "remove", "put",
                 "--episodes", "2", "--max-episode-steps", "40", "--out", str(report)]) == 0
    result = json.loads(report.read_text())
    assert result["episodes"] == 2 and "successes_after_retry" in result["by_family"]["remove"]
    record = result["records"][0]
    assert record["steps"] >= 1 and {"retries", "exclusion"} <= set(record["diagnosis"])
    # the rule fired exactly when the instruction has an unheard word in a noun's place (a 3-scene
    # vocabulary is small: it may)
    fires = bool(unknown_nouns(record["instruction"], KeyposeConfig.from_dict(config).vocabulary))
    assert record["diagnosis"]["exclusion"] is fires
    assert np.isfinite(record["diagnosis"]["decisions"][0]["grasp"]).all()


@pytest.mark.slow
def test_several_datasets_train_one_keypose_policy_together(every_family_dataset: Path, tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    """A family that a dataset of all families gives few demonstrations of comes from a dataset of its
    own: the episodes of both are learnt from, both datasets are recorded; datasets of another scene
    camera, or several datasets for another model, are refused in one line before anything is written."""
    from samplehd.cli import main
    from samplehd.dataset.config import GenerateConfig, preset_config
    from samplehd.dataset.generate import generate_dataset

    stacks = tmp_path / "stacks"
    generate_dataset(stacks, GenerateConfig.from_dict(
        {**EVERY_FAMILY, "num_scenes": 2, "seed": 9, "instructions": {"per_scene": 2, "families": ["stack"]}},
        base=preset_config("small")))
    one, both = tmp_path / "one", tmp_path / "both"
    for out, datasets in ((one, [every_family_dataset]), (both, [every_family_dataset, stacks])):
        assert main(["train", "policy", "--action", "keypose", "--dataset", *map(str, datasets), "--out", str(out),
                     "--steps", "2", "--batch", "2", "--quiet"]) == 0
    alone, together = (json.loads((o / "config.json").read_text()) for o in (one, both))
    assert together["dataset"] == str(every_family_dataset) and together["more_datasets"] == [str(stacks)]
    assert alone["more_datasets"] == []
    assert together["train"]["episodes"] > alone["train"]["episodes"]
    assert (json.loads((both / "metrics.json").read_text())["train_decisions"]
            > json.loads((one / "metrics.json").read_text())["train_decisions"])

    small = tmp_path / "small"
    generate_dataset(small, GenerateConfig.from_dict(
        {**EVERY_FAMILY, "num_scenes": 1, "render": {"mode": "none", "width": 96, "height": 54}},
        base=preset_config("small")))
    refused = tmp_path / "refused"
    assert main(["train", "policy", "--action", "keypose", "--dataset", str(stacks), str(small), "--out",
                 str(refused), "--steps", "2", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"--dataset {small}: scene camera 96x54 px, the first dataset's ({stacks}) 160x90 px" in err, err
    assert main(["train", "parser", "--dataset", str(stacks), str(small), "--out", str(refused)]) == 2
    assert "several datasets train only `train policy --action keypose`" in capsys.readouterr().err
    assert not refused.exists()
