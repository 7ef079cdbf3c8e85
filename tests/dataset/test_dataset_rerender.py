"""`samplehd rerender --add`: new cameras beside the stored ones, each at its own resolution; resume; replace."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from samplehd.cli import main
from samplehd.dataset.container import camera_settings, merge_camera_settings, read_meta
from samplehd.dataset.reader import DatasetReader
from samplehd.dataset.render import RenderConfig
from samplehd.dataset.rerender import rerender_dataset
from samplehd.dataset.validate import validate_dataset
from samplehd.errors import DatasetError
from samplehd.scene.spec import SceneSpec

ADD_WRIST = ["--add", "--cameras", "wrist", "--width", "48", "--height", "48", "--modalities", "rgb", "depth",
             "--workers", "1", "--quiet"]


@pytest.fixture(scope="module")
def added_dataset(rendered_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The 64×36 scene-camera dataset with a 48×48 wrist camera (rgb, depth) added; the first
    episode got its wrist images first, as an interrupted run leaves it."""
    from samplehd.dataset.work import RenderUnit, run_render_unit

    out = tmp_path_factory.mktemp("added") / "ds"
    shutil.copytree(rendered_dataset, out)
    reader = DatasetReader(out)
    e = reader.episodes[0]
    physics_hz = float(reader.config.get("paths", {}).get("physics_hz", 500.0))
    wrist = RenderConfig("fast", 48, 48, ("wrist",), ("rgb", "depth"))
    done = run_render_unit(RenderUnit(str(out / e.file), SceneSpec.from_dict(reader.scene(e.scene_index)["spec"]),
                                      physics_hz, wrist, replace=False))
    # an interrupted rerender has recorded each finished episode in info.json, and that it is under way
    info = json.loads((out / "info.json").read_text())
    info["episodes"][0].update(size=done.size, sha256=done.sha256)
    info["rerender"] = {"render": info.get("render"), "episodes": len(info["episodes"]), "done": 1}
    (out / "info.json").write_text(json.dumps(info, indent=1))
    res = rerender_dataset(out, wrist, add=True)
    assert res["skipped"] == 1 and res["rendered"] == res["episodes"] - 1  # resumed: episode 0 was done
    return out


def _raw_chunks(path: Path, key: str) -> list[bytes]:
    with h5py.File(path, "r") as f:
        ds = f[key]
        return [ds.id.read_direct_chunk((t,) + (0,) * (ds.ndim - 1))[1] for t in range(ds.shape[0])]


def test_add_keeps_the_stored_camera_and_adds_one_at_its_own_size(rendered_dataset: Path,
                                                                  added_dataset: Path) -> None:
    before, after = DatasetReader(rendered_dataset), DatasetReader(added_dataset)
    assert validate_dataset(added_dataset)[0] == []
    for k in range(len(after)):
        meta = after.episode_meta(k)
        assert {c: sorted(m) for c, m in meta.images.items()} == {
            "scene": ["depth", "rgb", "segmentation"], "wrist": ["depth", "rgb"]}
        assert camera_settings(meta.render) == {
            "scene": {"mode": "fast", "width": 64, "height": 36, "modalities": ["rgb", "depth", "segmentation"]},
            "wrist": {"mode": "fast", "width": 48, "height": 48, "modalities": ["rgb", "depth"]}}
        old, new = before.episode(k, images="load"), after.episode(k)
        for mod, arr in old.images["scene"].items():  # the old images are untouched, chunk for chunk
            stored = np.asarray(new.images["scene"][mod])
            assert stored.dtype == arr.dtype and np.array_equal(stored, arr), mod
            key = f"images/scene/{mod}"
            assert _raw_chunks(after.episode_path(k), key) == _raw_chunks(before.episode_path(k), key)
        assert new.images["wrist"]["rgb"].shape == (new.num_frames, 48, 48, 3)
        assert new.images["wrist"]["depth"].shape == (new.num_frames, 48, 48)
        assert np.isfinite(after.image(k, "wrist", "depth", 0)).all()
    info = json.loads((added_dataset / "info.json").read_text())
    assert info["render"]["cameras"] == ["scene", "wrist"] and info["render"]["mode"] == "fast"
    assert info["render"]["width"] is None and info["render"]["modalities"] is None  # cameras differ
    assert camera_settings(info["render"]) == camera_settings(after.episode_meta(0).render)
    assert info["render_history"][-1]["width"] == 64


def test_exports_read_cameras_of_different_sizes(added_dataset: Path, tmp_path: Path) -> None:
    import av

    out = tmp_path / "lr"
    assert main(["export", "lerobot", str(added_dataset), "--out", str(out), "--codec", "libx264",
                 "--modalities", "rgb", "depth", "segmentation"]) == 0
    feats = json.loads((out / "meta" / "info.json").read_text())["features"]
    assert feats["observation.images.scene"]["shape"] == [36, 64, 3]
    assert feats["observation.images.wrist"]["shape"] == [48, 48, 3]
    assert feats["depth.wrist"]["shape"][:2] == [48, 48]  # depth is opt-in, exact, outside observation.*
    assert "segmentation.wrist" not in feats  # not stored for the wrist
    with av.open(str(out / "videos/observation.images.wrist/chunk-000/file-000.mp4")) as c:
        frame = next(c.decode(video=0))
        assert (frame.width, frame.height) == (48, 48)


def test_same_add_again_skips_every_episode(added_dataset: Path, tmp_path: Path,
                                            capsys: pytest.CaptureFixture) -> None:
    copy = tmp_path / "ds"
    shutil.copytree(added_dataset, copy)
    digests = [e["sha256"] for e in json.loads((copy / "info.json").read_text())["episodes"]]
    assert main(["rerender", str(copy), *ADD_WRIST]) == 0
    n = len(digests)
    assert f"added images to 0 episodes ({n} already done)" in capsys.readouterr().out
    assert [e["sha256"] for e in json.loads((copy / "info.json").read_text())["episodes"]] == digests
    # A modality of a stored camera at the same settings is added beside the others.
    res = rerender_dataset(copy, RenderConfig("fast", 48, 48, ("wrist",), ("segmentation",)), add=True)
    assert res["rendered"] == n
    assert sorted(read_meta(DatasetReader(copy).episode_path(0))["images"]["wrist"]) == [
        "depth", "rgb", "segmentation"]
    assert validate_dataset(copy)[0] == []


def test_replace_drops_the_other_cameras(added_dataset: Path, tmp_path: Path) -> None:
    copy = tmp_path / "ds"
    shutil.copytree(added_dataset, copy)
    res = rerender_dataset(copy, RenderConfig("fast", 32, 32, ("wrist",), ("rgb",)))
    assert res["rendered"] == res["episodes"] and not res["add"]
    reader = DatasetReader(copy)
    assert all(reader.episode_meta(k).images == {"wrist": ("rgb",)} for k in range(len(reader)))
    assert reader.info["render"]["width"] == 32 and reader.info["render"]["cameras"] == ["wrist"]
    assert validate_dataset(copy)[0] == []


def test_add_errors_are_one_line(added_dataset: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    copy = tmp_path / "ds"
    shutil.copytree(added_dataset, copy)
    assert main(["rerender", str(copy), "--add", "--cameras", "top_view", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "unknown camera(s) ['top_view']" in err and "wrist" in err
    # Re-rendering only some modalities of a stored camera at another size would mix two settings.
    args = ["rerender", str(copy), "--add", "--cameras", "scene", "--width", "32", "--height", "18",
            "--modalities", "rgb", "--quiet"]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "camera 'scene' is stored at 64x36 fast with depth, segmentation" in err
    assert ".h5" in err and "Traceback" not in err
    assert validate_dataset(copy)[0] == []  # nothing was written


def test_merge_camera_settings() -> None:
    old = {"scene": {"mode": "fast", "width": 64, "height": 36, "modalities": ["rgb", "depth"]}}
    # A camera rendered again with all its modalities at a new size is replaced whole.
    out = merge_camera_settings(old, RenderConfig("hd", 32, 32, ("scene", "wrist"), ("depth", "rgb")), add=True)
    assert out == {c: {"mode": "hd", "width": 32, "height": 32, "modalities": ["rgb", "depth"]}
                   for c in ("scene", "wrist")}
    assert merge_camera_settings(old, RenderConfig("fast", 64, 36, ("scene",), ("segmentation",)), add=True) == {
        "scene": {"mode": "fast", "width": 64, "height": 36, "modalities": ["rgb", "depth", "segmentation"]}}
    with pytest.raises(DatasetError, match="stored at 64x36 fast with depth"):
        merge_camera_settings(old, RenderConfig("fast", 32, 18, ("scene",), ("rgb",)), add=True)
    assert merge_camera_settings(old, RenderConfig("fast", 32, 18, ("wrist",), ("rgb",)), add=False) == {
        "wrist": {"mode": "fast", "width": 32, "height": 18, "modalities": ["rgb"]}}
