"""The catalogue is explicit: imported classes take part only when named, and are recorded by hash."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import trimesh

from samplehd.catalogue import load_catalogue
from samplehd.catalogue.importer import ImportOptions, import_mesh
from samplehd.dataset.config import GenerateConfig
from samplehd.dataset.generate import _base_info, generate_dataset
from samplehd.dataset.layout import INFO_FILE
from samplehd.errors import ConfigError
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import sample_scene
from samplehd.world.seeding import scene_seed


def _import_block(tmp_path: Path, name: str) -> None:
    src = tmp_path / f"{name}.stl"
    trimesh.creation.box((0.05, 0.04, 0.08)).export(src)
    import_mesh(src, name, options=ImportOptions(), materials=("plastic",))


def test_imported_classes_change_nothing_unless_named(tmp_path: Path) -> None:
    before = load_catalogue().record()
    scenes = [sample_scene(i, scene_seed(11, i)).scene.to_dict() for i in range(2)]
    _import_block(tmp_path, "tall_block")
    assert load_catalogue().record() == before and "tall_block" not in load_catalogue().classes
    assert [sample_scene(i, scene_seed(11, i)).scene.to_dict() for i in range(2)] == scenes
    # a config that names the class draws it
    named = SceneConfig(min_objects=2, max_objects=2, classes=("tall_block",))
    drawn = sample_scene(0, scene_seed(11, 0), named).scene
    assert [o.instance.class_name for o in drawn.objects] == ["tall_block", "tall_block"]


def test_resume_refuses_a_changed_catalogue(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _import_block(tmp_path, "brick_a")
    config = GenerateConfig.from_dict({"num_scenes": 1, "scene": {"classes": ["brick_a", "mug", "bowl"]}})
    out = tmp_path / "ds"
    out.mkdir()
    info = _base_info(config)
    assert set(info["catalogue"]["imported"]) == {"brick_a"}
    (out / INFO_FILE).write_text(json.dumps(info))
    # the imported class changes on disk (re-imported with another size) after the dataset started
    src = tmp_path / "brick_a.stl"
    import_mesh(src, "brick_a", options=ImportOptions(size=0.06), materials=("plastic",), overwrite=True)
    with pytest.raises(ConfigError) as exc:
        generate_dataset(out, config, resume=True)
    message = str(exc.value)
    assert "\n" not in message and "catalogue" in message and "brick_a" in message
    assert sorted(p.name for p in out.iterdir()) == [INFO_FILE]  # nothing written
