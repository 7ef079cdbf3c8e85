"""``validate --deep`` means "safe to train on": every file a trainer or exporter reads (the scene
images, depth and segmentation, the scene camera, the stored config) is checked, and the keypose
trainer, which reads them all, refuses the same damage in one line before it writes anything.

A tiny dataset with 64×36 scene images is made once; each case damages a copy of it, runs the real
command (``samplehd.cli.main``) and compares the copy's bytes before and after.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)
from samplehd.cli import main

SCENE_IMAGES = {
    "num_scenes": 2,
    "seed": 0,
    "test_every": 2,
    "scene": {"min_objects": 3, "max_objects": 3},
    "instructions": {"per_scene": 1, "families": ["pick_up"]},
    "render": {"mode": "none", "width": 64, "height": 36},
}
FIRST = "SHD_train_000000"


def _tree(root: Path) -> dict[str, str]:
    """Every path under ``root`` with the SHA-256 of its bytes ('dir' for folders)."""
    return {str(p.relative_to(root)): "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*"))}


def _edit_json(path: Path, change: Callable[[Any], None]) -> None:
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc))


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


# (id, how the copy is damaged, the file the message must name, a fragment of the message)
DAMAGES: list[tuple[str, Callable[[Path], None], str, str]] = [
    ("images-deleted", lambda d: shutil.rmtree(d / "images"), f"images/{FIRST}.png", "missing"),
    ("png-truncated", lambda d: _truncate(d / "images" / f"{FIRST}.png"), f"images/{FIRST}.png", "truncated"),
    ("depth-npy-text", lambda d: (d / "depth" / f"{FIRST}.npy").write_text("0.5 0.5\n"), f"depth/{FIRST}.npy",
     ".npy"),
    ("segmentation-deleted", lambda d: (d / "segmentation" / f"{FIRST}.png").unlink(),
     f"segmentation/{FIRST}.png", "missing"),
    ("depth-png-is-rgb", lambda d: shutil.copyfile(d / "images" / f"{FIRST}.png", d / "depth" / f"{FIRST}.png"),
     f"depth/{FIRST}.png", "mode RGB"),
    ("depth-npy-wrong-size", lambda d: np.save(d / "depth" / f"{FIRST}.npy", np.zeros((36, 32), np.float32)),
     f"depth/{FIRST}.npy", "(36, 32)"),
    ("scene-without-camera", lambda d: _edit_json(d / "scenes.json", lambda doc: doc["scenes"][0].pop("camera")),
     "scenes.json", "camera"),
    ("camera-bad-intrinsics", lambda d: _edit_json(
        d / "scenes.json", lambda doc: doc["scenes"][0]["camera"].update(intrinsics=[[1, 0], [0, 1]])),
     "scenes.json", "camera.intrinsics"),
    ("config-catalogue-ikea", lambda d: _edit_json(
        d / "info.json", lambda doc: doc["config"]["scene"].update(catalogue="ikea")),
     "info.json", "procedural, shop-vrb"),
    ("recorded-catalogue-ikea", lambda d: _edit_json(
        d / "info.json", lambda doc: doc["catalogue"].update(name="ikea")),
     "info.json", "procedural, shop-vrb"),
]


@pytest.fixture(scope="module")
def scene_image_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A complete dataset: 2 scenes with 64×36 scene images, one pick_up episode each (states only)."""
    from samplehd.dataset.config import GenerateConfig, preset_config
    from samplehd.dataset.generate import generate_dataset

    out = tmp_path_factory.mktemp("scene_images") / "ds"
    summary = generate_dataset(out, GenerateConfig.from_dict(SCENE_IMAGES, base=preset_config("tiny")))
    assert summary.episodes >= 2
    return out


def _damaged(src: Path, dst: Path, damage: Callable[[Path], None]) -> Path:
    shutil.copytree(src, dst)
    damage(dst)
    return dst


@pytest.mark.parametrize(("damage", "file", "fragment"), [pytest.param(d, f, m, id=i) for i, d, f, m in DAMAGES])
def test_validate_deep_finds_what_the_trainers_read(scene_image_dataset, tmp_path, damage, file, fragment,
                                                    capsys) -> None:
    ds = _damaged(scene_image_dataset, tmp_path / "ds", damage)
    before = _tree(tmp_path)
    assert main(["validate", str(ds), "--deep"]) == 1
    out = capsys.readouterr().out
    lines = [line for line in out.splitlines() if str(ds / file) in line]
    assert lines and fragment in lines[0], out
    assert _tree(tmp_path) == before


@pytest.mark.parametrize(("damage", "file", "fragment"), [pytest.param(d, f, m, id=i) for i, d, f, m in DAMAGES])
def test_keypose_trainer_refuses_the_same_damage_before_writing(scene_image_dataset, tmp_path, damage, file,
                                                                fragment, capsys) -> None:
    pytest.importorskip("torch")
    ds = _damaged(scene_image_dataset, tmp_path / "ds", damage)
    before = _tree(tmp_path)
    code = main(["train", "policy", "--action", "keypose", "--dataset", str(ds), "--out", str(tmp_path / "model"),
                 "--steps", "1", "--batch", "2", "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert str(ds / file) in err and fragment in err, err
    assert _tree(tmp_path) == before  # no half-made --out, the dataset untouched


def test_a_dataset_validate_deep_passes_trains(scene_image_dataset, tmp_path, capsys) -> None:
    pytest.importorskip("torch")
    assert main(["validate", str(scene_image_dataset), "--deep"]) == 0
    out = tmp_path / "model"
    assert main(["train", "policy", "--action", "keypose", "--dataset", str(scene_image_dataset), "--out", str(out),
                 "--steps", "1", "--batch", "2", "--quiet"]) == 0
    assert (out / "model.pt").is_file()
