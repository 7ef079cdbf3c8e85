"""The `samplehd instructions` and `samplehd vocab` commands."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from samplehd.cli import main
from samplehd.language.executor import execute
from samplehd.language.synthetic import synthetic_scenes_file


@pytest.fixture()
def scenes_file(tmp_path: Path) -> Path:
    path = tmp_path / "scenes" / "scenes.json"
    path.parent.mkdir()
    path.write_text(json.dumps(synthetic_scenes_file(np.random.default_rng(2), 25)))
    return path


def test_instructions_and_vocab(tmp_path: Path, scenes_file: Path) -> None:
    out = tmp_path / "instructions.json"
    argv = [
        "instructions",
        "--scenes",
        str(scenes_file.parent),
        "--out",
        str(out),
        "--per-scene",
        "4",
        "--seed",
        "3",
        "--split-ratio",
        "train=0.8,test=0.2",
        "--quiet",
    ]
    assert main(argv) == 0
    doc = json.loads(out.read_text())
    entries = doc["instructions"]
    assert entries and doc["info"]["seed"] == 3
    assert {e["split"] for e in entries} <= {"train", "test"}
    scenes = json.loads(scenes_file.read_text())["scenes"]
    keys = {
        "split",
        "image_index",
        "image_filename",
        "instruction_index",
        "instruction",
        "template_filename",
        "template_index",
        "family",
        "task",
        "targets",
        "program",
        "program_sequence",
    }
    for e in entries:
        assert keys <= set(e)
        scene = scenes[e["image_index"]]
        for program in (e["program"], e["program_sequence"]):
            task = execute(program, scene)
            assert task.to_program_dict() == e["task"]
            assert list(task.involved) == e["targets"]
    first = out.read_bytes()
    assert main(argv) == 0 and out.read_bytes() == first  # same seed, same file

    vocab = tmp_path / "vocab.json"
    assert main(["vocab", "--instructions", str(out), "--out", str(vocab)]) == 0
    v = json.loads(vocab.read_text())
    assert v["instruction_token_to_idx"]["<NULL>"] == 0 and v["program_token_to_idx"]["<UNK>"] == 3


def test_families_option(tmp_path: Path, scenes_file: Path) -> None:
    out = tmp_path / "i.json"
    assert (
        main(["instructions", "--scenes", str(scenes_file), "--out", str(out), "--families", "stack", "put", "--quiet"])
        == 0
    )
    assert {e["family"] for e in json.loads(out.read_text())["instructions"]} <= {"stack", "put"}


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--families", "juggle"], "--families: unknown 'juggle'"),
        (["--per-scene", "0"], "--per-scene"),
        (["--split-ratio", "oops"], "NAME=FRACTION"),
    ],
)
def test_bad_input_exits_2(
    tmp_path: Path, scenes_file: Path, capsys: pytest.CaptureFixture[str], extra: list, message: str
) -> None:
    code = main(["instructions", "--scenes", str(scenes_file), "--out", str(tmp_path / "i.json"), "--quiet", *extra])
    assert code == 2
    assert message in capsys.readouterr().err


def test_missing_scenes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["instructions", "--scenes", str(tmp_path / "none"), "--out", str(tmp_path / "i.json")]) == 2
    assert "no such file or folder" in capsys.readouterr().err
    assert main(["vocab", "--instructions", str(tmp_path / "none.json"), "--out", str(tmp_path / "v.json")]) == 2
