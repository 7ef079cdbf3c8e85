"""Export a samplehd dataset in the original SAMPLE-HD folder layout.

::

    images/<scene stem>.png                 the scene images (SHD_<split>_<index:06d>.png)
    scenes/<scene stem>.json                one CLEVR-layout scene annotation each
    instructions/i<instruction:06d>.json    one instruction each (text, programs, task, targets, ...)
    sequences/i<instruction:06d>_s<scene:06d>/
        data.json                           the episode: header + one record per frame
        <frame:05d>_rgb.png                 per camera suffix when several: <frame:05d>_<camera>_rgb.png
        <frame:05d>_depth.png               uint16 millimetres
        <frame:05d>_seg.png                 instance ids (0 background, 1 table, 2 robot, 3+i object i)
        preview.mp4                         with --previews (H.264)

A frame record of data.json: ``frame``, ``time`` [s], ``subtask`` (SAMPLE-HD's names), ``subtask_index``,
``subtask_progress``, ``target_object``, ``joints`` (6 arm angles [deg], as SAMPLE-HD's Unity
recorder), ``joints_rad``, ``gripper_opening`` [m], ``steering`` (7 values in [-1, 1]),
``effector`` {position [m], rotation (quaternion w,x,y,z)}, ``objects`` [{id, position, rotation}],
``grasped_object``, ``safety_event``. Sequences end with the ``Succeeded`` / ``Completed`` markers.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.dataset.container import read_episode
from samplehd.dataset.staging import export_source, staged_directory
from samplehd.render.image_io import save_depth, save_rgb, save_segmentation
from samplehd.render.video import VideoWriter
from samplehd.workers import Backend

__all__ = ["export_samplehd", "sequence_name"]


def sequence_name(instruction_index: int, scene_index: int) -> str:
    """SAMPLE-HD's sequence folder name."""
    return f"i{instruction_index:06d}_s{scene_index:06d}"


@dataclass(frozen=True)
class _SequenceUnit:
    episode_path: str
    out: str
    instruction_index: int
    instruction: dict[str, Any]
    images: bool
    previews: bool
    fps: int


def _frame_records(ep: Any) -> list[dict[str, Any]]:
    f = ep.frames
    out = []
    for t in range(ep.num_frames):
        out.append({
            "frame": t,
            "time": round(float(f["time"][t]), 6),
            "subtask": ep.subtasks[int(f["subtask_index"][t])],
            "subtask_index": int(f["subtask_index"][t]),
            "subtask_progress": round(float(f["subtask_progress"][t]), 5),
            "target_object": int(f["target_object"][t]),
            "joints": np.degrees(f["joint_pos"][t]).round(5).tolist(),
            "joints_rad": f["joint_pos"][t].tolist(),
            "gripper_opening": round(float(f["gripper_opening"][t]), 6),
            "gripper_command": float(f["gripper_command"][t]),
            "steering": [round(float(v), 6) for v in f["steering"][t]],
            "effector": {"position": f["tcp_pos"][t].tolist(), "rotation": f["tcp_quat"][t].tolist()},
            "objects": [{"id": i, "position": p.tolist(), "rotation": q.tolist()}
                        for i, (p, q) in enumerate(zip(f["object_pos"][t], f["object_quat"][t], strict=True))],
            "grasped_object": int(f["grasped_object"][t]),
            "safety_event": int(f["safety_event"][t]),
        })
    return out


def _export_sequence(unit: _SequenceUnit) -> int:
    ep = read_episode(Path(unit.episode_path), images="lazy" if unit.images or unit.previews else "none")
    folder = Path(unit.out) / "sequences" / sequence_name(unit.instruction_index, ep.scene_index)
    folder.mkdir(parents=True, exist_ok=True)
    inst = unit.instruction
    doc = {
        "instruction_index": unit.instruction_index, "scene_index": ep.scene_index,
        "instruction": inst.get("instruction"), "family": ep.family, "task": inst.get("task"),
        "program": inst.get("program"), "program_sequence": inst.get("program_sequence"),
        "targets": inst.get("targets"), "seed": ep.seed, "success": ep.success, "subtasks": list(ep.subtasks),
        "fps": unit.fps, "num_frames": ep.num_frames, "markers": ["Succeeded", "Completed"] if ep.success else [],
        "check": ep.info.get("check"), "frames": _frame_records(ep),
    }
    (folder / "data.json").write_text(json.dumps(doc))
    cams = list(ep.images)
    if unit.images:
        for cam in cams:
            tag = "" if len(cams) == 1 else f"_{cam}"
            mods = ep.images[cam]
            for t in range(ep.num_frames):
                if "rgb" in mods:
                    save_rgb(folder / f"{t:05d}{tag}_rgb.png", mods["rgb"][t])
                if "depth" in mods:
                    save_depth(folder / f"{t:05d}{tag}_depth.png", mods["depth"][t])
                if "segmentation" in mods:
                    save_segmentation(folder / f"{t:05d}{tag}_seg.png", mods["segmentation"][t])
    if unit.previews and cams and "rgb" in ep.images[cams[0]]:
        rgb = ep.images[cams[0]]["rgb"][:]
        h, w = rgb.shape[1] // 2 * 2, rgb.shape[2] // 2 * 2
        with VideoWriter(folder / "preview.mp4", w, h, unit.fps, "libx264", crf=23, gop=unit.fps) as vw:
            vw.write(rgb[:, :h, :w])
    return ep.num_frames


def export_samplehd(root: str | Path, out: str | Path, images: bool = True, previews: bool = False,
                    backend: Backend | None = None, progress: Callable[[int, int], None] | None = None
                    ) -> dict[str, Any]:
    """Write the SAMPLE-HD layout of a complete dataset into ``out`` (a temporary folder, renamed).

    Args:
        root: the samplehd dataset.
        out: the new folder (must not exist or be empty).
        images: write per-frame PNGs (when the episodes store images).
        previews: write ``preview.mp4`` per sequence (first camera's RGB).
        backend: where sequences are written (default: in this process).
        progress: ``progress(done, total)`` per sequence.

    Returns:
        ``{scenes, instructions, sequences, frames}``.
    """
    reader, out = export_source(root, out)
    fps = int(round(float(reader.config.get("paths", {}).get("control_hz", 20.0))))
    with staged_directory(out) as tmp:
        for sub in ("images", "scenes", "instructions", "sequences"):
            (tmp / sub).mkdir(parents=True, exist_ok=True)
        root = Path(root)
        for s in reader.scenes:
            stem = Path(s["image_filename"]).stem
            (tmp / "scenes" / f"{stem}.json").write_text(json.dumps(s))
            src = root / "images" / f"{stem}.png"
            if src.exists():
                shutil.copyfile(src, tmp / "images" / f"{stem}.png")
        for i, inst in enumerate(reader.instructions):
            (tmp / "instructions" / f"i{i:06d}.json").write_text(json.dumps(inst))
        units = [_SequenceUnit(str(reader.episode_path(i)), str(tmp), i, reader.instruction(i), images, previews, fps)
                 for i in range(len(reader))]
        frames = 0
        for done, (_, n) in enumerate((backend or Backend()).map(_export_sequence, iter(units)), 1):
            frames += n
            if progress:
                progress(done, len(units))
        (tmp / "info.json").write_text(json.dumps({"source": str(root.resolve()), "layout": "SAMPLE-HD",
                                                   "fps": fps, "info": reader.info.get("counts")}, indent=1))
    return {"scenes": len(reader.scenes), "instructions": len(reader), "sequences": len(reader), "frames": frames}
