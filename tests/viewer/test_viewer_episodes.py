"""Episodes through the real dataset reader, on a copy of a dataset made by ``samplehd generate``
taken back to a state it passes through while generating, then completed."""

from __future__ import annotations

import json
from io import BytesIO
from pathlib import Path

import numpy as np
from dataset_states import DatasetFiles, finish_generation, stop_generation_midway
from PIL import Image

from samplehd.dataset.reader import DatasetReader
from samplehd.viewer.app import ViewerApp
from samplehd.viewer.episodes import failure_reason, subtask_segments
from samplehd.viewer.server import open_dataset


def test_episodes_of_a_dataset_being_generated(dataset_copy: Path, dataset_files: DatasetFiles) -> None:
    files = dataset_files
    # scene 0's episode is written and journaled, one of scene 1's is written but its journal line is
    # half appended, another one is being written; scene 0's rejected path is journaled
    by_scene = {i: [s for s, e in zip(files.stems, files.episodes, strict=True) if e["scene_index"] == i]
                for i in (0, 1)}
    assert by_scene[0] and len(by_scene[1]) >= 2, "the tiny dataset's episodes changed; pick others"
    written, unlogged, writing = by_scene[0][0], by_scene[1][0], by_scene[1][1]
    stop_generation_midway(dataset_copy, files, written, unlogged, writing)
    app = ViewerApp(open_dataset(dataset_copy, render=False))
    status = json.loads(app.handle("/api/status", {}).body)
    states = {f["name"]: f for f in status["files"]}
    assert states["episodes"]["state"] == "partial" and "2 episodes" in states["episodes"]["detail"]
    assert "candidates" in states["instructions.json"]["detail"]
    assert states["scenes.json"]["state"] == "missing" and status["counts"]["scenes"] == len(files.scenes)
    listing = json.loads(app.handle("/api/episodes", {}).body)
    assert [e["episode"] for e in listing["episodes"]] == [written, unlogged]
    entries = {s: e for s, e in zip(files.stems, files.episodes, strict=True)}
    first, second = listing["episodes"]
    assert first["success"] is True and first["num_frames"] == entries[written]["num_frames"]  # from the journal
    assert second["num_frames"] == -1  # frame count unknown until the journal says
    candidate = files.candidate(entries[written]["scene_index"], entries[written]["slot"])
    assert first["instruction"] == candidate["instruction"]
    expected = []
    for r in files.rejections:
        c = files.candidate(r["scene_index"], r["slot"])
        expected.append({"scene_index": r["scene_index"], "slot": r["slot"], "reason": r["reason"],
                         "message": r["message"], "instruction_index": files.candidates.index(c),
                         "instruction": c["instruction"], "family": c["family"],
                         "program_sequence": c["program_sequence"]})
    assert listing["rejections"] == expected  # while generating, candidates stand in for instructions
    scene = json.loads(app.handle("/api/scenes/0", {}).body)
    outcomes = {q["slot"]: (len(q["episodes"]), len(q["rejections"])) for q in scene["instructions"]}
    assert outcomes == {q["slot"]: ((1, 0) if f"s000000_{q['slot']:02d}" == written else
                                    (0, 1) if any(r["scene_index"] == 0 and r["slot"] == q["slot"]
                                                  for r in files.rejections) else (0, 0))
                        for q in files.candidates if q["image_index"] == 0}
    failed = json.loads(app.handle("/api/scenes", {"success": "failure"}).body)
    assert [s["index"] for s in failed["scenes"]] == sorted({r["scene_index"] for r in files.rejections})

    detail = json.loads(app.handle(f"/api/episodes/{written}", {}).body)
    render = files.info["config"]["render"]
    assert detail["cameras"] == {c: sorted(render["modalities"]) for c in render["cameras"]}
    reader = DatasetReader(files.root)
    index = files.stems.index(written)
    meta = reader.episode_meta(index)
    n = entries[written]["num_frames"]
    assert detail["num_frames"] == n and detail["next"] == unlogged and detail["previous"] is None
    names = list(meta.subtasks)
    assert {g["name"] for g in detail["segments"]} <= set(names) and detail["segments"][-1]["end"] == n
    steering = reader.frames(index, ["steering"])["steering"]
    assert len(detail["series"]["steering"]) == n
    np.testing.assert_allclose(detail["series"]["steering"], steering, atol=1e-5)
    camera = render["cameras"][0]
    rgb = app.handle(f"/api/episodes/{written}/frame/5", {"camera": camera, "modality": "rgb"})
    assert rgb.status == 200
    pixels = np.asarray(Image.open(BytesIO(rgb.body)))
    np.testing.assert_array_equal(pixels, np.asarray(reader.image(index, camera, "rgb", 5)))
    assert pixels.shape == (render["height"], render["width"], 3)
    for modality in ("depth", "segmentation"):
        assert app.handle(f"/api/episodes/{written}/frame/5", {"modality": modality}).status == 200
    assert app.handle(f"/api/episodes/{written}/frame/{n}", {}).status == 404
    assert app.handle(f"/api/episodes/{writing}", {}).status == 404  # only a temporary file so far
    assert [p.name for p in (dataset_copy / "episodes").iterdir() if p.name.startswith(f".{writing}")]

    # generation finishes: episodes and journal complete, then scenes.json, instructions.json, info.json
    finish_generation(dataset_copy, files)
    status = json.loads(app.handle("/api/status", {}).body)
    assert {f["name"]: f["state"] for f in status["files"]} == {
        "info.json": "ok", "scenes.json": "ok", "instructions.json": "ok", "episodes": "ok"}
    assert status["counts"]["episodes"] == len(files.episodes)
    listing = json.loads(app.handle("/api/episodes", {}).body)
    assert [e["episode"] for e in listing["episodes"]] == files.stems
    assert [e["num_frames"] for e in listing["episodes"]] == [e["num_frames"] for e in files.episodes]
    rejected = files.rejections[0]
    scene = json.loads(app.handle(f"/api/scenes/{rejected['scene_index']}", {}).body)
    assert scene["rejections"][0]["instruction"] == files.candidate(rejected["scene_index"],
                                                                      rejected["slot"])["instruction"]
    assert scene["rejections"][0]["instruction_index"] is None  # a candidate, not a dataset instruction


def test_failure_reason_and_segments() -> None:
    assert failure_reason(True, {"check": {"reason": "x"}}) == ""
    assert failure_reason(False, {"check": {"reason": "object 2 not in part left"}}) == "object 2 not in part left"
    assert failure_reason(False, {"failed_attempts": [{"reason": "r", "message": "m"}]}) == "m"
    assert failure_reason(False, {}) == ""
    segments = subtask_segments(np.array([0, 0, 1, 1, 1, 0]), np.array([2, 2, 2, 3, 3, 3]), ["A", "B"])
    assert [(g["start"], g["end"], g["name"], g["target"]) for g in segments] == [
        (0, 2, "A", 2), (2, 3, "B", 2), (3, 5, "B", 3), (5, 6, "A", 3)]
