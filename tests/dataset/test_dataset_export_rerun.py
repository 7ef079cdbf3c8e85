"""`samplehd export rerun`: an episode as a Rerun recording, read back with rerun-sdk's own RRD reader."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np
from rerun.chunk import RrdReader

from samplehd.cli import main
from samplehd.dataset.reader import DatasetReader


def _read(path: Path) -> tuple[dict[str, list], dict[str, dict]]:
    """Per entity: the time-indexed rows (frame, {component: value}) and the static components."""
    rows: dict[str, list] = defaultdict(list)
    static: dict[str, dict] = defaultdict(dict)
    for chunk in RrdReader(path).stream().to_chunks():
        batch = chunk.to_record_batch()
        comps = [n for n in batch.schema.names if ":" in n]
        for i in range(batch.num_rows):
            values = {n: batch.column(n)[i].as_py() for n in comps}
            if chunk.is_static:
                static[chunk.entity_path].update({k: v for k, v in values.items() if v is not None})
            else:
                rows[chunk.entity_path].append((batch.column("frame")[i].as_py(), values))
    return rows, static


def test_episode_recording_holds_scene_cameras_series_and_subtasks(rendered_dataset: Path, tmp_path: Path) -> None:
    reader = DatasetReader(rendered_dataset)
    episode_file = rendered_dataset / reader.episodes[0].file
    out = tmp_path / "ep.rrd"
    assert main(["export", "rerun", str(episode_file), "--out", str(out)]) == 0
    ep = reader.episode(0)
    rows, static = _read(out)
    n = ep.num_frames
    for entity in ("/joints/elbow", "/gripper/opening", "/gripper/command", "/steering/vx", "/steering/gripper",
                   "/subtask/index", "/world/camera/scene/rgb", "/world/camera/scene/depth",
                   "/world/camera/scene/segmentation", "/world/object_0", "/world/robot_wrist_3_link"):
        assert sorted(f for f, _ in rows[entity]) == list(range(n)), entity
    elbow = dict((f, v["Scalars:scalars"]) for f, v in rows["/joints/elbow"])
    assert np.allclose([np.ravel(elbow[t])[0] for t in range(n)], ep.frames["joint_pos"][:, 2])
    # Objects move as recorded: the body transform is the recorded object position.
    obj = dict((f, v["Transform3D:translation"]) for f, v in rows["/world/object_0"])
    assert np.allclose([np.ravel(obj[t]) for t in range(n)], ep.frames["object_pos"][:, 0], atol=1e-6)
    # Static meshes under the bodies: objects, arm links, the table.
    meshes = [e for e, c in static.items() if "Mesh3D:vertex_positions" in c]
    assert any(e.startswith("/world/object_0/") for e in meshes)
    assert any(e.startswith("/world/robot_forearm_link/") for e in meshes) and any("table" in e for e in meshes)
    # One log line per subtask start, then the markers.
    changes = 1 + int(np.count_nonzero(np.diff(ep.frames["subtask_index"])))
    texts = [np.ravel(v["TextLog:text"])[0] for _, v in sorted(rows["/subtask"], key=lambda r: r[0])]
    assert len(texts) == changes + 2 and texts[-2:] == ["Succeeded", "Completed"]
    assert texts[0] == ep.subtasks[int(ep.frames["subtask_index"][0])]
    assert "Pinhole:image_from_camera" in static["/world/camera/scene"]
    img = rows["/world/camera/scene/rgb"][0][1]
    assert any(k.startswith("Image:") for k in img)


def test_rerun_errors_are_one_line(rendered_dataset: Path, tmp_path: Path, capsys) -> None:
    assert main(["export", "rerun", str(rendered_dataset), "--out", str(tmp_path / "x.mp4")]) == 2
    assert ".rrd" in capsys.readouterr().err
    assert main(["export", "rerun", str(rendered_dataset), "--episode", "999", "--out", str(tmp_path / "x.rrd")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "episode 999" in err and not (tmp_path / "x.rrd").exists()
