"""`rerender --preset photo --every N --subtask-ends`: keyframe images, recorded frame indices, resume."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mitsuba", reason="the photo preset needs samplehd[photo]")

W, H = 32, 18


@pytest.fixture(scope="module")
def keyframed(tmp_path_factory: pytest.TempPathFactory, micro_dataset: Path) -> tuple[Path, dict]:
    from samplehd.dataset.render import RenderConfig
    from samplehd.dataset.rerender import rerender_dataset
    from samplehd.workers import Backend

    out = tmp_path_factory.mktemp("photo") / "ds"
    shutil.copytree(micro_dataset, out)
    render = RenderConfig("photo", W, H, ("scene",), ("rgb", "segmentation"), every=40, subtask_ends=True)
    res = rerender_dataset(out, render, Backend("local", 1))
    return out, res


def test_keyframes_are_rendered_and_recorded(keyframed: tuple[Path, dict]) -> None:
    from samplehd.dataset.container import read_episode, read_meta
    from samplehd.dataset.reader import DatasetReader
    from samplehd.errors import DatasetError
    from samplehd.render.keyframes import keyframe_indices

    root, res = keyframed
    reader = DatasetReader(root)
    assert res["rendered"] == len(reader.episodes) >= 1
    from samplehd.dataset.validate import validate_dataset

    problems, _ = validate_dataset(root, deep=True)
    assert problems == []
    info = json.loads((root / "info.json").read_text())
    assert info["render"]["per_camera"]["scene"]["every"] == 40
    assert info["render"]["per_camera"]["scene"]["subtask_ends"] is True
    for i, entry in enumerate(reader.episodes):
        path = root / entry.file
        meta = read_meta(path)
        ep = read_episode(path)
        want = keyframe_indices(ep.num_frames, 40, ep.frames["subtask_index"], True)
        assert meta["image_frames"]["scene"] == want.tolist()
        assert 0 in want and ep.num_frames - 1 in want and len(want) < ep.num_frames
        rgb = ep.images["scene"]["rgb"]
        assert len(rgb) == ep.num_frames and rgb.has_image(int(want[1])) and not rgb.has_image(1)
        assert rgb[int(want[-1])].shape == (H, W, 3) and rgb[int(want[-1])].mean() > 20
        assert rgb.stored().shape == (len(want), H, W, 3)
        with pytest.raises(DatasetError, match="frame 1 has no image; this camera has images at") as err:
            rgb[1]
        assert "\n" not in str(err.value)
        # Each subtask's first and last frame is among the keyframes.
        idx = ep.frames["subtask_index"]
        for s in np.unique(idx):
            where = np.flatnonzero(idx == s)
            assert where[0] in want and where[-1] in want
        # The loaded form keeps the keyframes.
        loaded = read_episode(path, images="load").images["scene"]["segmentation"]
        assert loaded.frames.tolist() == want.tolist() and loaded.images.shape == (len(want), H, W)
        assert reader.episode_meta(i) is not None


def test_rerender_resumes_where_it_stopped(keyframed: tuple[Path, dict], micro_dataset: Path) -> None:
    from samplehd.dataset.reader import DatasetReader
    from samplehd.dataset.render import RenderConfig
    from samplehd.dataset.rerender import rerender_dataset
    from samplehd.workers import Backend

    root, _ = keyframed
    render = RenderConfig("photo", W, H, ("scene",), ("rgb", "segmentation"), every=40, subtask_ends=True)
    again = rerender_dataset(root, render, Backend("local", 1))
    assert again["rendered"] == 0 and again["skipped"] == again["episodes"]
    # An episode the run did not reach (still states only, as in the source) is the only one rendered.
    first = DatasetReader(root).episodes[0].file
    shutil.copy(micro_dataset / first, root / first)
    # rerender records each episode in info.json as it replaces it: the one not reached keeps its old
    # record, and info.json says a rerender is under way (its render still the old one)
    info = json.loads((root / "info.json").read_text())
    source_info = json.loads((micro_dataset / "info.json").read_text())
    source = source_info["episodes"][0]
    info["episodes"][0].update(size=source["size"], sha256=source["sha256"])
    info["rerender"] = {"render": info["render"], "episodes": len(info["episodes"]), "done": len(info["episodes"]) - 1}
    info["render"] = source_info.get("render")
    (root / "info.json").write_text(json.dumps(info, indent=1))
    resumed = rerender_dataset(root, render, Backend("local", 1))
    assert resumed["rendered"] == 1 and resumed["skipped"] == resumed["episodes"] - 1


def test_bad_keyframe_options_are_one_line_errors_and_change_nothing(keyframed: tuple[Path, dict],
                                                                       capsys: pytest.CaptureFixture) -> None:
    from samplehd.cli import main

    root, _ = keyframed
    before = (root / "info.json").read_bytes()
    for argv, msg in (
        (["--every", "-2"], "render.every=-2 is invalid; valid: an integer >= 0"),
        (["--every", "0"], "render.every=0 renders no frame"),
        (["--photo-look", "sunny"], "render.look='sunny': valid: fixed, random"),
    ):
        code = main(["rerender", str(root), "--preset", "photo", "--width", "32", "--height", "18", *argv])
        err = capsys.readouterr().err.strip()
        assert code == 2 and msg in err and len(err.splitlines()) == 1, err
    assert (root / "info.json").read_bytes() == before


@pytest.mark.slow
def test_keyframe_rerender_on_ray(tmp_path: Path, micro_dataset: Path) -> None:
    pytest.importorskip("ray")
    from samplehd.dataset.container import read_meta
    from samplehd.dataset.reader import DatasetReader
    from samplehd.dataset.render import RenderConfig
    from samplehd.dataset.rerender import rerender_dataset
    from samplehd.workers import Backend

    out = tmp_path / "ds"
    shutil.copytree(micro_dataset, out)
    res = rerender_dataset(out, RenderConfig("photo", W, H, ("scene",), ("rgb",), every=0, subtask_ends=True),
                           Backend("ray", 2))
    assert res["rendered"] >= 1
    for e in DatasetReader(out).episodes:
        assert read_meta(out / e.file)["image_frames"]["scene"]


def test_viewer_knows_which_frames_have_images(keyframed: tuple[Path, dict]) -> None:
    from io import BytesIO

    from PIL import Image

    from samplehd.dataset.reader import DatasetReader
    from samplehd.viewer.app import ViewerApp
    from samplehd.viewer.server import open_dataset

    root, _ = keyframed
    reader = DatasetReader(root)
    name = Path(reader.episodes[0].file).stem
    app = ViewerApp(open_dataset(root, render=False))
    detail = json.loads(app.handle(f"/api/episodes/{name}", {}).body)
    frames = detail["image_frames"]["scene"]
    assert frames == list(reader.episode_meta(0).image_frames["scene"])
    # A frame between two keyframes shows the keyframe before it.
    t = next(k for k in range(frames[0], frames[-1]) if k not in frames)
    before = max(f for f in frames if f <= t)
    got = app.handle(f"/api/episodes/{name}/frame/{t}", {"camera": "scene", "modality": "rgb"})
    assert got.status == 200
    np.testing.assert_array_equal(np.asarray(Image.open(BytesIO(got.body))), reader.image(0, "scene", "rgb", before))


def test_sample_hd_export_writes_the_keyframes_and_lerobot_says_it_needs_every_frame(
        keyframed: tuple[Path, dict], tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from samplehd.cli import main
    from samplehd.dataset.reader import DatasetReader
    from samplehd.export.sample_hd import export_samplehd

    root, _ = keyframed
    export_samplehd(root, tmp_path / "shd")
    reader = DatasetReader(root)
    jpgs = sorted((tmp_path / "shd").rglob("sequence_img_*.jpg"))
    # Only frames that have images are written: at least one per episode, fewer than all frames.
    assert len(jpgs) >= len(reader.episodes)
    assert len(jpgs) < sum(e.num_frames for e in reader.episodes)
    code = main(["export", "lerobot", str(root), "--out", str(tmp_path / "lr")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "has no image; this camera has images at" in err and len(err.splitlines()) == 1, err
