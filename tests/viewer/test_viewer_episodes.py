"""Episodes through the real dataset reader: a small ``samplehd generate``-layout folder written with
the dataset's own episode writer (synthetic frames), in progress and complete."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from viewer_fakes import make_fake_dataset

from samplehd.record.episode import FRAME_FIELDS, SUBTASK_NAMES, Episode
from samplehd.viewer.app import ViewerApp
from samplehd.viewer.episodes import failure_reason, subtask_segments
from samplehd.viewer.server import open_dataset

T, H, W = 30, 36, 64


def _episode(scene: int, slot: int, family: str, images: bool) -> Episode:
    dims = {"N": 3, "nq": 10, "nv": 9, "na": 0}
    frames = {}
    for key, (shape, dtype) in FRAME_FIELDS.items():
        full = (T, *(dims[s] if isinstance(s, str) else s for s in shape))
        frames[key] = np.zeros(full, dtype=dtype)
    frames["time"] = np.arange(T) / 20.0
    frames["subtask_index"] = np.repeat(np.arange(3), T // 3).astype("i2")
    frames["target_object"][:] = 1
    frames["steering"][:, 0] = np.linspace(-1, 1, T)
    frames["joint_pos"][:, 2] = np.sin(frames["time"])
    frames["gripper_opening"][:] = 0.08
    frames["tcp_pos"][:] = (0.1, 0.0, 0.9)
    pictures: dict[str, dict[str, np.ndarray]] = {}
    if images:
        rgb = np.zeros((T, H, W, 3), np.uint8)
        for t in range(T):
            rgb[t, :, t % W] = (255, 0, 0)
        pictures = {"scene": {"rgb": rgb, "depth": np.full((T, H, W), 1.25, np.float32),
                              "segmentation": np.full((T, H, W), 3, np.uint8)}}
    return Episode(scene_index=scene, instruction_index=slot, family=family, seed=7, subtasks=SUBTASK_NAMES[:3],
                   frames=frames, success=True, info={"control_hz": 20.0, "check": {"success": True, "reason": ""}},
                   images=pictures)


@pytest.fixture()
def generated(tmp_path: Path) -> Path:
    """A dataset in the middle of ``samplehd generate``: two episodes written, one path rejected."""
    pytest.importorskip("h5py")
    from samplehd.dataset.container import write_episode

    root = make_fake_dataset(tmp_path / "generated", num_scenes=3)
    doc = json.loads((root / "instructions.json").read_text())
    (root / "candidates.json").write_text(json.dumps(doc))
    (root / "instructions.json").unlink()
    (root / "info.json").write_text(json.dumps({"format_version": "1.0", "status": "in_progress"}))
    (root / "episodes").mkdir()
    for scene, slot, images in ((0, 0, True), (1, 2, False)):
        q = next(q for q in doc["instructions"] if q["image_index"] == scene and q["slot"] == slot)
        write_episode(root / "episodes" / f"s{scene:06d}_{slot:02d}.h5", _episode(scene, slot, q["family"], images),
                      extra={"slot": slot, "instruction": q["instruction"], "task": q["task"]},
                      render={"mode": "fast", "width": W, "height": H} if images else None)
    (root / "episodes" / ".s000002_00.h5.tmp-123").write_bytes(b"half")
    (root / "journal.jsonl").write_text(json.dumps({"scene_index": 0, "slot": 1, "status": "rejected",
                                                    "reason": "checker_failed", "message": "object 0 not on 1"})
                                        + "\n" + '{"scene_index": 2, "slo')  # torn last line
    return root


def test_episodes_of_a_dataset_being_generated(generated: Path) -> None:
    app = ViewerApp(open_dataset(generated))
    status = json.loads(app.handle("/api/status", {}).body)
    states = {f["name"]: f for f in status["files"]}
    assert states["episodes"]["state"] == "partial" and "2 episodes" in states["episodes"]["detail"]
    assert "candidates" in states["instructions.json"]["detail"]
    listing = json.loads(app.handle("/api/episodes", {}).body)
    assert [e["episode"] for e in listing["episodes"]] == ["s000000_00", "s000001_02"]
    first = listing["episodes"][0]
    assert first["success"] is True and first["num_frames"] == -1  # frame count unknown until the journal says
    assert first["instruction"] == "Put the mug on the left."
    assert listing["rejections"] == [{"scene_index": 0, "slot": 1, "reason": "checker_failed",
                                      "message": "object 0 not on 1", "instruction_index": 1,
                                      "instruction": "Stack the mug onto the bowl.", "family": "stack",
                                      "program_sequence": "stack scene filter_name[mug] scene filter_name[bowl]"}]
    scene = json.loads(app.handle("/api/scenes/0", {}).body)
    outcomes = [(len(q["episodes"]), len(q["rejections"])) for q in scene["instructions"]]
    assert outcomes == [(1, 0), (0, 1)]
    failed = json.loads(app.handle("/api/scenes", {"success": "failure"}).body)
    assert [s["index"] for s in failed["scenes"]] == [0]

    detail = json.loads(app.handle("/api/episodes/s000000_00", {}).body)
    assert detail["cameras"] == {"scene": ["depth", "rgb", "segmentation"]}
    assert detail["num_frames"] == T and detail["next"] == "s000001_02" and detail["previous"] is None
    assert [g["name"] for g in detail["segments"]] == list(SUBTASK_NAMES[:3])
    assert len(detail["series"]["steering"]) == T and detail["series"]["steering"][0][0] == -1.0
    rgb = app.handle("/api/episodes/s000000_00/frame/5", {"camera": "scene", "modality": "rgb"})
    assert rgb.status == 200
    from io import BytesIO

    from PIL import Image

    pixels = np.asarray(Image.open(BytesIO(rgb.body)))
    assert pixels.shape == (H, W, 3) and tuple(pixels[0, 5]) == (255, 0, 0)
    for modality in ("depth", "segmentation"):
        assert app.handle("/api/episodes/s000000_00/frame/5", {"modality": modality}).status == 200
    assert app.handle("/api/episodes/s000000_00/frame/30", {}).status == 404
    no_images = app.handle("/api/episodes/s000001_02/frame/0", {})
    assert no_images.status == 404 and b"no images" in no_images.body
    assert app.handle("/api/episodes/s000002_00", {}).status == 404  # only a temporary file so far

    # generation finishes: info.json lists the episodes, instructions.json is written
    shutil.copy(generated / "candidates.json", generated / "instructions.json")
    info = {"format_version": "1.0", "status": "complete", "episodes": [
        {"instruction_index": 0, "scene_index": 0, "slot": 0, "file": "episodes/s000000_00.h5", "seed": 7,
         "family": "place", "split": "train", "num_frames": T},
        {"instruction_index": 1, "scene_index": 1, "slot": 2, "file": "episodes/s000001_02.h5", "seed": 7,
         "family": "pick_up", "split": "train", "num_frames": T}]}
    (generated / "info.json").write_text(json.dumps(info))
    status = json.loads(app.handle("/api/status", {}).body)
    assert {f["name"]: f["state"] for f in status["files"]}["episodes"] == "ok"
    assert status["counts"]["episodes"] == 2
    (generated / "instructions.json").write_text(json.dumps({"info": {}, "instructions": [
        {**q, "instruction_index": n} for n, q in enumerate(
            q for q in json.loads((generated / "candidates.json").read_text())["instructions"]
            if (q["image_index"], q["slot"]) in ((0, 0), (1, 2)))]}))
    scene = json.loads(app.handle("/api/scenes/0", {}).body)
    assert [r["instruction"] for r in scene["rejections"]] == ["Stack the mug onto the bowl."]
    assert scene["rejections"][0]["instruction_index"] is None  # a candidate, not a dataset instruction


def test_failure_reason_and_segments() -> None:
    assert failure_reason(True, {"check": {"reason": "x"}}) == ""
    assert failure_reason(False, {"check": {"reason": "object 2 not in part left"}}) == "object 2 not in part left"
    assert failure_reason(False, {"failed_attempts": [{"reason": "r", "message": "m"}]}) == "m"
    assert failure_reason(False, {}) == ""
    segments = subtask_segments(np.array([0, 0, 1, 1, 1, 0]), np.array([2, 2, 2, 3, 3, 3]), ["A", "B"])
    assert [(g["start"], g["end"], g["name"], g["target"]) for g in segments] == [
        (0, 2, "A", 2), (2, 3, "B", 2), (3, 5, "B", 3), (5, 6, "A", 3)]
