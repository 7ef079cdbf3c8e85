"""Mesh import end to end: read, clean, normalise, CoACD, cache, register, use in MuJoCo."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from samplehd.catalogue import ObjectInstance, add_object, load_catalogue, object_facts
from samplehd.catalogue.importer import ImportOptions, import_mesh, read_mesh
from samplehd.catalogue.registry import cache_dir, registry_dir, remove_imported
from samplehd.errors import AssetError, ConfigError


def _ell_mesh(path: Path) -> Path:
    """A non-convex L-shaped block with a duplicate and two degenerate faces (CoACD aborts on those)."""
    a = trimesh.creation.box((0.08, 0.03, 0.02))
    b = trimesh.creation.box((0.03, 0.03, 0.08))
    b.apply_translation((0.025, 0.0, 0.03))
    ell = trimesh.boolean.union([a, b], engine="manifold")
    v = np.vstack([ell.vertices, ell.vertices[:1]])
    f = np.vstack([ell.faces, ell.faces[:3], [[0, 0, 1]], [[0, 1, len(v) - 1]]])
    trimesh.Trimesh(v, f, process=False).export(path)
    return path


def test_import_end_to_end(tmp_path: Path) -> None:
    src = _ell_mesh(tmp_path / "ell.obj")
    cls, report = import_mesh(src, "ell_block", options=ImportOptions(size=0.12), materials=("plastic", "wooden"))
    assert not report["cached"] and report["pieces"] >= 2  # non-convex: more than one convex piece
    assert max(report["extents"]) == pytest.approx(0.12)
    assert (registry_dir() / "ell_block" / "class.json").is_file()
    assert list((cache_dir() / "decompositions").glob("*.npz"))
    # the built-in catalogue is unchanged; a catalogue that names the class holds it, with its hash
    assert "ell_block" not in load_catalogue().classes
    assert load_catalogue().record()["imported"] == {}
    cat = load_catalogue(["ell_block"])
    assert cat.classes["ell_block"].imported
    assert set(cat.record()["imported"]) == {"ell_block"}
    assert cat.record()["built_in"] == load_catalogue().record()["built_in"]
    assert cat.record()["sha256"] != load_catalogue().record()["sha256"]
    menu = cat.classes["ell_block"].variants["default"].menu
    assert menu.material == ("plastic", "wooden") and "transparent" not in menu.colour
    inst = ObjectInstance("ell_block", "default", "red", "plastic", "medium")
    facts = object_facts(inst)
    assert facts.bbox_min[2] == pytest.approx(0.0, abs=1e-9)
    assert facts.mass == pytest.approx(1100.0 * report["volume"], rel=1e-6)
    assert facts.graspable_sites and facts.affordances.graspable
    # it builds and rests on a table
    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.5, 0.5, 0.02], pos=[0, 0, -0.02])
    add_object(spec, inst, "object_0", pos=(0, 0, 0.01))
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 800)
    assert abs(data.qpos[2]) < 2e-3 and 1 - 2 * (data.qpos[4] ** 2 + data.qpos[5] ** 2) > 0.999
    assert model.body("object_0").mass[0] == pytest.approx(facts.mass, rel=1e-3)

    # a second import of the same file and parameters uses the cache and gives the same pieces
    _, again = import_mesh(src, "ell_block", options=ImportOptions(size=0.12), overwrite=True)
    assert again["cached"] and again["pieces"] == report["pieces"]
    with pytest.raises(AssetError, match="already registered"):
        import_mesh(src, "ell_block", options=ImportOptions(size=0.12))
    remove_imported("ell_block")
    with pytest.raises(AssetError, match="neither built-in nor imported"):
        load_catalogue(["ell_block"])


def test_import_convex_stl_without_scaling(tmp_path: Path) -> None:
    src = tmp_path / "brick.stl"
    trimesh.creation.box((0.05, 0.03, 0.1)).export(src)
    cls, report = import_mesh(src, "brick")
    assert report["pieces"] == 1
    np.testing.assert_allclose(sorted(report["extents"]), [0.03, 0.05, 0.1], atol=1e-6)
    meta = json.loads((registry_dir() / "brick" / "geometry.json").read_text())
    assert meta["source_sha256"] and len(meta["principal_axes"]) == 2
    assert min(g["width"] for g in meta["grasps"]) == pytest.approx(0.03, abs=1e-6)


@pytest.mark.parametrize("suffix", [".ply", ".glb", ".obj"])
def test_import_formats(tmp_path: Path, suffix: str) -> None:
    src = tmp_path / f"cyl{suffix}"
    trimesh.creation.cylinder(radius=0.03, height=0.1, sections=24).export(src)
    _, report = import_mesh(src, "cyl")
    np.testing.assert_allclose(report["extents"], [0.06, 0.06, 0.1], atol=2e-3)
    facts = object_facts(ObjectInstance("cyl", "default", "blue", "plastic", "small"))
    assert facts.height == pytest.approx(0.08, abs=2e-3)
    assert facts.top.flat


@pytest.mark.parametrize(
    ("name", "content", "expected"),
    [
        ("bad.stl", b"this is not a mesh", "bad.stl: "),
        ("empty.obj", b"v 0 0 0\n", "empty.obj: the mesh is empty"),
        ("notes.txt", b"hello", "unsupported mesh format .txt; use one of .obj, .stl, .ply, .glb"),
        ("flat.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n", "flat.obj: "),
    ],
)
def test_bad_mesh_files_give_one_line_errors(tmp_path: Path, name: str, content: bytes, expected: str) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(AssetError) as info:
        import_mesh(path, "thing")
    assert expected in str(info.value) and "\n" not in str(info.value)
    assert not (registry_dir() / "thing").exists()


def test_point_cloud_is_not_a_mesh(tmp_path: Path) -> None:
    path = tmp_path / "cloud.ply"
    trimesh.PointCloud(np.random.default_rng(0).random((30, 3))).export(path)
    with pytest.raises(AssetError, match="cloud.ply"):
        read_mesh(path)


def test_import_argument_errors(tmp_path: Path) -> None:
    src = tmp_path / "big.stl"
    trimesh.creation.box((50.0, 30.0, 100.0)).export(src)  # millimetres
    with pytest.raises(AssetError, match=r"pass `scale` \(e.g. 0.001 for millimetres\)"):
        import_mesh(src, "box_mm")
    cls, report = import_mesh(src, "box_mm", options=ImportOptions(scale=0.001))
    assert max(report["extents"]) == pytest.approx(0.1)
    with pytest.raises(AssetError, match="built-in class"):
        import_mesh(src, "mug", options=ImportOptions(scale=0.001))
    with pytest.raises(AssetError, match="name='Big Box'"):
        import_mesh(src, "Big Box", options=ImportOptions(scale=0.001))
    with pytest.raises(AssetError, match="unknown material 'stone'"):
        import_mesh(src, "box2", options=ImportOptions(scale=0.001), materials=("stone",))
    with pytest.raises(ConfigError, match=r"ImportOptions.scale=-1.0: must be a finite number > 0"):
        ImportOptions(scale=-1.0)
