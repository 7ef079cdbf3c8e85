"""Trained models' ``config.json`` is a typed config: it round-trips, and a damaged file is refused in
one line naming the file, the field, the value and what is valid."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from samplehd.errors import ConfigError


@pytest.fixture(scope="module")
def trained(nano_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from samplehd.learn.parser import ParserConfig, ParserTraining, train_parser
    from samplehd.learn.perception import PerceptionConfig, PerceptionTraining, train_perception
    from samplehd.learn.policy import PolicyConfig, PolicyTraining, train_policy

    out = tmp_path_factory.mktemp("models")
    train_parser(nano_dataset, out / "parser", ParserConfig(train=ParserTraining(steps=2)), quiet=True, device="cpu")
    train_perception(nano_dataset, out / "perception", PerceptionConfig(train=PerceptionTraining(steps=2)), quiet=True,
                     device="cpu")
    train_policy(nano_dataset, out / "policy", PolicyConfig(train=PolicyTraining(steps=2)), quiet=True, device="cpu")
    return out


def _config(kind: str) -> Any:
    from samplehd.learn.parser import ParserConfig
    from samplehd.learn.perception import PerceptionConfig
    from samplehd.learn.policy import PolicyConfig

    return {"parser": ParserConfig, "perception": PerceptionConfig, "policy": PolicyConfig}[kind]


def _load(kind: str, folder: Path) -> Any:
    from samplehd.learn.parser import InstructionParser
    from samplehd.learn.perception import Perception
    from samplehd.learn.policy import BCPolicy

    return {"parser": InstructionParser, "perception": Perception, "policy": BCPolicy}[kind].load(folder)


@pytest.mark.parametrize("kind", ["parser", "perception", "policy"])
def test_config_json_is_the_typed_config_written_out(trained: Path, kind: str) -> None:
    written = json.loads((trained / kind / "config.json").read_text())
    config = _config(kind).from_dict(written)
    assert config.to_dict() == written
    assert _load(kind, trained / kind).config == config


DAMAGES: list[tuple[str, Callable[[dict], None], str]] = [
    ("parser", lambda d: d["model"].update(embed=0), "model.embed=0: must be an integer ≥ 1"),
    ("parser", lambda d: d.update(bogus=1), "unknown option(s) ['bogus']"),
    ("parser", lambda d: d.update(target_vocab="x"), "parser.target_vocab='x'"),
    ("perception", lambda d: d["image"].update(width="wide"), "image.width='wide': must be an integer"),
    ("perception", lambda d: d["train"].update(lr=-1), "train.lr=-1: must be a finite number > 0"),
    ("perception", lambda d: d["attributes"].pop("size"), "perception.attributes"),
    ("perception", lambda d: d.update(kinds=["nope/a/b"]), "'nope/a/b'"),
    ("policy", lambda d: d["inference"].update(ensemble=-1), "inference.ensemble=-1: must be a finite number ≥ 0"),
    ("policy", lambda d: d["inference"].update(zero_channels=[6]), "zero_channels[0]=6: must be an integer in [0, 5]"),
    ("policy", lambda d: d.update(inputs="depth"), "policy.inputs='depth': valid: rgb, state"),
    ("policy", lambda d: d["model"].update(encoder="vit"), "model.encoder='vit': valid: flatten, keypoints"),
    ("policy", lambda d: d["train"].update(bogus=1), "unknown option(s) ['bogus']"),
    ("policy", lambda d: d.update(image=0), "policy.image=0"),
    ("policy", lambda d: d.update(catalogue="ikea"), "policy.catalogue='ikea': valid: procedural, shop-vrb"),
]


@pytest.mark.parametrize(("kind", "damage", "fragment"), [pytest.param(k, d, f, id=f"{k}-{i}")
                                                          for i, (k, d, f) in enumerate(DAMAGES)])
def test_a_damaged_config_json_is_one_line_naming_file_and_field(trained: Path, tmp_path: Path, kind: str,
                                                                 damage: Callable[[dict], None],
                                                                 fragment: str) -> None:
    folder = tmp_path / kind
    folder.mkdir()
    (folder / "model.pt").write_bytes((trained / kind / "model.pt").read_bytes())
    doc = json.loads((trained / kind / "config.json").read_text())
    damage(doc)
    (folder / "config.json").write_text(json.dumps(doc))
    with pytest.raises(ConfigError) as info:
        _load(kind, folder)
    text = str(info.value)
    assert "\n" not in text and text.startswith(f"{folder / 'config.json'}: ") and fragment in text, text


def test_a_policy_config_json_of_an_earlier_version_still_loads(trained: Path, tmp_path: Path) -> None:
    """Format-3 files written before ``inputs``, ``action``, ``model.encoder`` and
    ``inference.zero_channels`` existed load as the policy those versions trained, and so do those that
    held the keypose policy's ``grid`` and ``train.init``."""
    from samplehd.learn.policy import BCPolicy

    doc = json.loads((trained / "policy" / "config.json").read_text())
    for key in ("inputs", "action"):
        doc.pop(key)
    doc["model"].pop("encoder")
    doc["inference"].pop("zero_channels")
    # the keypose policy's keys, which every policy file held before it had its own config
    doc["grid"] = {"camera": "scene", "width": 640, "height": 360, "origin": [-0.512, -0.64], "cell": 0.008,
                   "rows": 128, "cols": 160}
    doc["train"]["init"] = ""
    folder = tmp_path / "old"
    folder.mkdir()
    (folder / "model.pt").write_bytes((trained / "policy" / "model.pt").read_bytes())
    (folder / "config.json").write_text(json.dumps(doc))
    config = BCPolicy.load(folder).config
    assert (config.inputs, config.action, config.model.encoder, config.inference.zero_channels) == (
        "rgb", "steering", "flatten", ())


def test_a_keypose_policy_config_json_of_an_earlier_version_loads_as_a_keypose_config() -> None:
    """Keypose policies were written with the behaviour-cloning policy's keys (``image``, ``chunk``,
    ``inference``, ``collect``, its network and training options); they read as the keypose config,
    those keys dropped, and ask the environment for what the keypose policy needs."""
    from samplehd.learn.keypose.configuration import KeyposeConfig
    from samplehd.learn.options import policy_config_class
    from samplehd.learn.policy.configuration import PolicyConfig

    doc = {"kind": "policy", "format": 3, "dataset": "ds", "catalogue": "procedural", "inputs": "rgb",
           "action": "keypose", "image": 0, "chunk": 1, "execute": 1, "tokens": 32,
           "model": {"width": 16, "hidden": 128, "state_dim": 23, "encoder": "flatten"},
           "inference": {"ensemble": None, "z_floor": None, "zero_channels": []},
           "grid": {"camera": "scene", "width": 320, "height": 180, "origin": [-0.512, -0.64], "cell": 0.008,
                    "rows": 128, "cols": 160},
           "families": ["pick_up", "place"],
           "collect": {"demos": 0, "noise": 0.0, "dagger_rounds": 0, "dagger_episodes": 50, "dagger_steps": 1000},
           "train": {"steps": 12, "seed": 1, "batch": 4, "stride": 1, "lr": 0.001, "loss": "mse", "near_weight": 1.0,
                     "gripper_weight": 1.0, "episodes": 4, "frames": 0, "init": ""}}
    assert policy_config_class(doc) is KeyposeConfig
    assert policy_config_class({**doc, "action": "waypoint"}) is PolicyConfig
    config = KeyposeConfig.from_dict(doc)
    assert (config.grid.width, config.model.width, config.train.batch, config.train.seed) == (320, 16, 4, 1)
    written = config.to_dict()
    assert not {"image", "chunk", "execute", "inference", "collect"} & set(written)
    assert set(written["model"]) == {"width", "grasp_head", "placed_count"} and "stride" not in written["train"]
    # what it was trained with
    assert config.model.grasp_head == "film" and not config.model.placed_count and config.train.attribute_weight == 0.5
    assert KeyposeConfig.from_dict(written) == config
    assert config.env_options() == {"obs_mode": "state", "control_mode": "steering",
                                    "scene": {"catalogue": "procedural"}}
    # One written before catalogues had names was trained on procedural scenes.
    assert KeyposeConfig.from_dict({k: v for k, v in doc.items() if k != "catalogue"}).catalogue == "procedural"
    with pytest.raises(ConfigError, match="policy.action='steering': valid: keypose"):
        KeyposeConfig.from_dict({**doc, "action": "steering"})
