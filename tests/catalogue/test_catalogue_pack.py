"""The shipped pack of imported classes (``data/imported_pack``): found by name without the user
registry, reserved against the importer, hash-checked, and physically sound in a scene."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest

from samplehd.catalogue import GRIPPER_STROKE, ObjectInstance, add_object, catalogue_for, load_catalogue, object_facts
from samplehd.catalogue.imported import load_imported_geometry
from samplehd.catalogue.loader import CATALOGUES, DATA_DIR, PACK, pack_classes
from samplehd.catalogue.registry import registered_classes
from samplehd.cli import main
from samplehd.errors import AssetError

PACK_DIR = DATA_DIR / PACK
PACK_CLASSES = ("bottle", "bread", "lemon")


def test_the_pack_loads_by_name_with_an_empty_registry() -> None:
    assert registered_classes() == ()  # tests/conftest.py: a private, empty registry
    assert pack_classes() == PACK_CLASSES
    for name in CATALOGUES:
        builtin = load_catalogue(name=name)
        assert not set(PACK_CLASSES) & set(builtin.classes)  # nothing that does not name them sees them
        assert catalogue_for(tuple(builtin.classes)[:3], name) is builtin
        cat = catalogue_for(("mug", *PACK_CLASSES), name)
        assert cat.name == name and list(cat.classes) == [*builtin.classes, *PACK_CLASSES]
        assert all(cat.classes[c].imported for c in PACK_CLASSES)
        record = cat.record()
        assert record["built_in"] == builtin.record()["built_in"] and set(record["imported"]) == set(PACK_CLASSES)
    lemon = catalogue_for(("lemon",)).record()["imported"]["lemon"]
    files = sorted(p for p in (PACK_DIR / "lemon").iterdir() if p.is_file())
    digest = hashlib.sha256()
    for p in files:
        digest.update(f"{p.name}\0{hashlib.sha256(p.read_bytes()).hexdigest()}\n".encode())
    assert lemon == digest.hexdigest()  # the record covers every file of the class


def test_the_provenance_lists_every_pack_file_and_its_sha256() -> None:
    text = (PACK_DIR / "files.md").read_text()
    listed = dict(re.findall(r"^\| (\w+/[\w.]+) \| ([0-9a-f]{64}) \|$", text, re.MULTILINE))
    on_disk = {f"{p.parent.name}/{p.name}": hashlib.sha256(p.read_bytes()).hexdigest()
               for c in PACK_CLASSES for p in (PACK_DIR / c).iterdir()}
    assert listed == on_disk
    assert "MIT License" in (PACK_DIR / "LICENSE").read_text() and "robosuite 1.5.1" in text
    size = sum(p.stat().st_size for p in PACK_DIR.rglob("*") if p.is_file())
    assert size < 100_000  # small enough to ship in the wheel


@pytest.mark.parametrize("name", PACK_CLASSES)
def test_a_pack_class_compiles_into_a_scene_settles_and_fits_the_gripper(name: str) -> None:
    cls = catalogue_for((name,)).object_class(name)
    menu = cls.variant("default").menu
    for size in menu.size:
        inst = ObjectInstance(name, "default", menu.colour[0], menu.material[0], size)
        facts = object_facts(inst)
        assert facts.graspable_sites and all(s.width <= GRIPPER_STROKE for s in facts.graspable_sites)
        assert 0.01 < facts.mass < 0.6  # light or medium: the gripper carries it
    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=(1, 1, 0.1))
    add_object(spec, ObjectInstance(name, "default", menu.colour[0], menu.material[0], "medium"), "object_0",
               pos=(0.0, 0.0, 0.002))
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 1000)  # 2 s
    assert np.linalg.norm(data.qvel) < 1e-2
    assert abs(data.qpos[2]) < 0.005 and np.linalg.norm(data.qpos[:2]) < 0.01  # resting where it was put
    assert abs(data.qpos[3]) > 0.99  # upright


def test_a_pack_mesh_that_does_not_match_its_digest_is_refused_in_one_line(tmp_path: Path) -> None:
    shutil.copytree(PACK_DIR / "lemon", tmp_path / "lemon")
    digest = json.loads((tmp_path / "lemon" / "class.json").read_text())["variants"]["default"]["geometry"]["digest"]
    npz = tmp_path / "lemon" / "geometry.npz"
    assert load_imported_geometry(npz, digest).faces.shape[1] == 3
    npz.write_bytes(npz.read_bytes() + b"\0")
    with pytest.raises(AssetError) as err:
        load_imported_geometry(npz, digest)
    assert "does not match its digest" in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("name", ["lemon", "mug"])
def test_the_importer_refuses_a_pack_or_built_in_name(name: str, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    mesh = tmp_path / "x.stl"
    shutil.copy(next((PACK_DIR / "lemon").glob("*.npz")), mesh)  # never read: the name is refused first
    assert main(["assets", "import", str(mesh), "--name", name]) == 2
    err = capsys.readouterr().err.strip()
    assert f"--name {name!r}" in err and "\n" not in err
    assert registered_classes() == ()
