"""Export a samplehd dataset as the files SAMPLE-HD's own Python code reads.

The layout, field names and conventions are those that SAMPLE-HD's ``model/executor.py``,
``tools/exec.py``, ``preprocessing/*.py``, ``datasets/SAMPLE.py`` and ``utils/robot.py`` consume::

    images/SAMPLE_HD_train_<scene:06d>.png         scene image (every split keeps this name, as theirs)
    depth/SAMPLE_HD_train_<scene:06d>.png          scene depth, uint16 millimetres
    segmentation/SAMPLE_HD_train_<scene:06d>.png   scene segmentation in colour (RGB, see below)
    scenes/SAMPLE_HD_train_<scene:06d>.json        CLEVR scene + SAMPLE-HD object fields
    instructions/instructions_program.json         {info, instructions: [...]}, sorted by instruction_idx
    instructions/instructions_unityGT_filtered.json  the ground-truth Unity programs, aligned with it
    sequences/i<instruction:06d>_s<scene:06d>/
        data.json                                  {scene_json, instruction_idx, sequence: [frame, ...]}
                                                   (+ disturbance: the label, and per frame
                                                   disturbance_active / recovery, in a disturbed episode)
        effector.json                              {data: [effector per frame_number]}
        sequence_img_<frame:05d>.jpg               RGB (JPEG, quality 95)
        segmentation/sequence_img_<frame:05d>.png  colour segmentation (RGB PNG)
        depth/sequence_img_<frame:05d>.png         uint16 millimetres
    info.json                                      counts and what was left out, with reasons

Only SAMPLE-HD's four families (place, stack, put, remove) are exported: its code cannot express
pick_up, place_relative or stack_three (``Executor.parse_unity`` reads ``'place' in
'place_relative'`` as place and crashes on pick_up). An instruction is also left out when one of its
``filter_table[P]`` tokens would select another set of objects on SAMPLE-HD's table, which has no
neutral band between halves (every exported object's ``table_part`` names one of left/right and
one of front/back, the nearer half where samplehd's object lies in the band). ``info.json`` counts
both. Positions, rotations, joint angles and effector points follow SAMPLE-HD's Unity conventions
(:mod:`samplehd.export.unity_frame`); docs/FORMAT.md documents every field.
"""

from __future__ import annotations

import json
import shutil
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from samplehd.dataset.container import read_episode
from samplehd.dataset.lock import dataset_lock
from samplehd.errors import DatasetError
from samplehd.export.staging import export_source, staged_directory
from samplehd.export.unity_frame import (
    joints_to_unity,
    point_to_unity,
    quat_to_unity,
    unity_effector_end,
    xyz,
    xyzw,
)
from samplehd.language.instruction_file import InstructionEntry
from samplehd.motion.order import pick_order
from samplehd.render.image_io import read_segmentation, save_depth
from samplehd.render.video import VideoWriter
from samplehd.scene.annotate import ObjectAnnotation, SceneAnnotation
from samplehd.tasks.task import Task, parse_task
from samplehd.workers import Backend
from samplehd.world.layout import LAYOUT

__all__ = [
    "MARKERS",
    "SAMPLE_HD_FAMILIES",
    "colour_segmentation",
    "approach_starts",
    "export_samplehd",
    "sample_hd_pick_order",
    "scene_stem",
    "segmentation_colour",
    "sequence_name",
    "unity_program",
]

SAMPLE_HD_FAMILIES = ("place", "stack", "put", "remove")
# Frames SAMPLE-HD appends to every successful sequence (its datasets/SAMPLE.py skips them).
MARKERS = ("Succeeded", "Completed")
_AXIS = {"left": 1, "right": 1, "front": 0, "back": 0}  # world axis that decides each part
_JPEG_QUALITY = 95
# Colours of the non-object classes of the colour segmentation (ids 0 background, 1 table, 2 robot):
# greys that no object colour comes near (every object colour has a channel at 0 or 255 and differs).
_CLASS_COLOURS = np.array([[0, 0, 0], [100, 100, 100], [200, 200, 200]], dtype=np.uint8)


def _object_palette() -> np.ndarray:
    levels = (0, 85, 170, 255)
    cols = [(r, g, b) for r in levels for g in levels for b in levels if not r == g == b]
    # Most saturated first, so scenes of few objects get the most distinct colours.
    cols.sort(key=lambda c: (-(max(c) - min(c)), -max(c), c))
    return np.array(cols, dtype=np.uint8)


_OBJECT_COLOURS = _object_palette()


def scene_stem(index: int) -> str:
    """SAMPLE-HD's name of scene ``index`` (its code reads ``SAMPLE_HD_train_%06d`` for every split)."""
    return f"SAMPLE_HD_train_{index:06d}"


def sequence_name(instruction_index: int, scene_index: int) -> str:
    """SAMPLE-HD's sequence folder name."""
    return f"i{instruction_index:06d}_s{scene_index:06d}"


def segmentation_colour(obj: int) -> dict[str, int]:
    """``segmentation_colour`` {r, g, b, a} (0–255) of scene object ``obj`` in the colour segmentation."""
    if not 0 <= obj < len(_OBJECT_COLOURS):
        raise ValueError(f"object {obj}: the colour segmentation has colours for objects 0..{len(_OBJECT_COLOURS) - 1}")
    r, g, b = (int(v) for v in _OBJECT_COLOURS[obj])
    return {"r": r, "g": g, "b": b, "a": 255}


def colour_segmentation(ids: np.ndarray, num_objects: int) -> np.ndarray:
    """H×W×3 uint8 colour image of instance ids (0 background, 1 table, 2 robot, 3 + i object i)."""
    lut = np.concatenate([_CLASS_COLOURS, _OBJECT_COLOURS[:num_objects]])
    ids = np.asarray(ids)
    if ids.size and (ids.min() < 0 or ids.max() >= len(lut)):
        raise ValueError(f"segmentation ids outside 0..{len(lut) - 1} for a scene of {num_objects} objects")
    return lut[ids]


def _sample_hd_table_part(obj: ObjectAnnotation) -> list[str]:
    """One of left/right and one of front/back: samplehd's parts, the nearer half where it lies in the band."""
    parts = list(obj.get("table_part") or [])
    x, y = obj["3d_coords"][0], obj["3d_coords"][1]
    horizontal = next((p for p in parts if p in ("left", "right")), "left" if y < 0 else "right")
    vertical = next((p for p in parts if p in ("front", "back")), "front" if x >= 0 else "back")
    return [horizontal, vertical]


def unity_program(instruction: InstructionEntry) -> dict[str, Any]:
    """The ground-truth ``unity_program`` {name, objectInt, subjectString, subjectInt} of an instruction
    of SAMPLE-HD's four families, from samplehd's task (what the ground-truth path carried out)."""
    return _sample_hd_task(instruction).to_sample_hd()  # remove is executed, and written, as a place


def _original_task(instruction: InstructionEntry) -> list[dict[str, Any]]:
    """SAMPLE-HD's ``task`` list [{type, object, subject}] (preprocessing/sequence_data_preprocessing.py)."""
    return [_sample_hd_task(instruction).to_sample_hd_task()]


def _sample_hd_task(instruction: InstructionEntry) -> Task:
    """The task of an instruction of one of SAMPLE-HD's families; raises ValueError for the others."""
    family = instruction["family"]
    if family not in SAMPLE_HD_FAMILIES:
        raise ValueError(f"family {family!r} has no SAMPLE-HD program; valid: {', '.join(SAMPLE_HD_FAMILIES)}")
    return parse_task(instruction["task"], family=family)


def _band_mismatch(tokens: list[str], strict: list[list[str]], sample_hd: list[list[str]]) -> bool:
    for tok in tokens:
        if tok.startswith("filter_table[") and tok.endswith("]"):
            part = tok[len("filter_table["):-1]
            if [part in p for p in strict] != [part in p for p in sample_hd]:
                return True
    return False


def _scene_doc(scene: SceneAnnotation, base: np.ndarray) -> dict[str, Any]:
    doc = {k: v for k, v in scene.items() if k != "spec"}
    doc["image_filename"] = scene_stem(int(scene["image_index"])) + ".png"
    rel = scene.get("relationships", {})
    objects = []
    for i, obj in enumerate(scene["objects"]):
        o = dict(obj)
        o["samplehd_table_part"] = list(obj.get("table_part") or [])
        o["table_part"] = _sample_hd_table_part(obj)
        o["segmentation_colour"] = segmentation_colour(i)
        o["position"] = xyz(point_to_unity(np.asarray(obj["3d_coords"]), base))
        o["rotation"] = xyzw(quat_to_unity(np.asarray(obj["orientation"])))
        ext = obj["bbox"]["extents"]  # object frame x, y, z [m] → Unity local x = y, y = z, z = x
        o["bounding_box_size"] = xyz((ext[1], ext[2], ext[0]))
        o["scaling"] = {"x": 1.0, "y": 1.0, "z": 1.0}
        o["directions"] = {r: list(rel[r][i]) for r in ("left", "right", "front", "behind") if r in rel}
        objects.append(o)
    doc["objects"] = objects
    return doc


@dataclass(frozen=True)
class _SequenceUnit:
    episode_path: str
    out: str
    instruction_index: int
    num_objects: int
    camera: str | None
    images: bool
    previews: bool
    fps: int
    base: tuple[float, float, float]


def approach_starts(subtasks: list[str]) -> list[int]:
    """Frames where a GripperMoveAvoid run begins (one per picked object)."""
    return [t for t, name in enumerate(subtasks)
            if name == "GripperMoveAvoid" and (t == 0 or subtasks[t - 1] != name)]


def sample_hd_pick_order(frames: list[dict[str, Any]], effector: list[dict[str, Any]]) -> tuple[list[int], list[int]]:
    """(the recorded pick order, the one SAMPLE-HD's preprocessing computes from the exported fields).

    ``preprocessing/sequence_data_preprocessing.py`` assigns the approaches to the moved objects
    greedily: for each GripperMoveAvoid in turn, the remaining object whose ``position`` in frame 0
    is nearest to the effector (``effector_end`` of ``robot_state``, i.e. ``effector.json``) at the
    approach's first frame.
    """
    starts = approach_starts([f["subtask"] for f in frames])
    recorded = [int(frames[t]["target_object"]) for t in starts]
    start_pos = np.array([list(o["position"].values()) for o in frames[0]["objects"]])
    effs = [np.array(list(effector[t]["position"].values())) for t in starts]
    return recorded, pick_order("nearest", sorted(recorded), effs, start_pos)


def _frame_records(ep: Any, base: np.ndarray) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    f = ep.frames
    joints = joints_to_unity(f["joint_pos"]).round(6)
    obj_pos = point_to_unity(f["object_pos"], base)
    obj_rot = quat_to_unity(f["object_quat"])
    eff = unity_effector_end(f["tcp_pos"], f["tcp_quat"], base)
    eff_rot = quat_to_unity(f["tcp_quat"])
    frames, effector = [], []
    for t in range(ep.num_frames):
        frames.append({
            "frame_number": t,
            "time": round(float(f["time"][t]), 6),
            "subtask": ep.subtasks[int(f["subtask_index"][t])],
            "robot_state": [float(v) for v in joints[t]] + [round(float(f["gripper_opening"][t]), 6)],
            "steering": [round(float(v), 6) for v in f["steering"][t]],
            "objects": [{"position": xyz(p), "rotation": xyzw(q)} for p, q in zip(obj_pos[t], obj_rot[t], strict=True)],
            "target_object": int(f["target_object"][t]),
            "grasped_object": int(f["grasped_object"][t]),
        })
        effector.append({"position": xyz(eff[t]), "rotation": xyzw(eff_rot[t])})
    if "disturbance" in ep.info:  # a disturbed episode's per-frame flags (samplehd.record.disturbances)
        for t, rec in enumerate(frames):
            rec["disturbance_active"] = bool(f["disturbance_active"][t])
            rec["recovery"] = bool(f["recovery"][t])
    last = ep.num_frames - 1
    for k, marker in enumerate(MARKERS if ep.success else MARKERS[1:]):
        frames.append({**frames[last], "frame_number": last + 1 + k, "subtask": marker})
        effector.append(effector[last])
    return frames, effector


def _export_sequence(unit: _SequenceUnit) -> tuple[int, bool]:
    """Write one sequence; returns (its frames, whether its pick order is the one SAMPLE-HD's
    preprocessing computes)."""
    want_images = unit.images or unit.previews
    ep = read_episode(Path(unit.episode_path), images="lazy" if want_images else "none")
    base = np.asarray(unit.base)
    folder = Path(unit.out) / "sequences" / sequence_name(unit.instruction_index, ep.scene_index)
    folder.mkdir(parents=True, exist_ok=True)
    frames, effector = _frame_records(ep, base)
    doc = {"scene_json": scene_stem(ep.scene_index) + ".json", "instruction_idx": unit.instruction_index,
           "fps": unit.fps, "sequence": frames}
    if "disturbance" in ep.info:
        doc["disturbance"] = ep.info["disturbance"]
    (folder / "data.json").write_text(json.dumps(doc))
    (folder / "effector.json").write_text(json.dumps({"data": effector}))
    mods = ep.images.get(unit.camera, {}) if unit.camera else {}
    if unit.images and mods:
        last = ep.num_frames - 1
        for fr in frames:
            t, name = min(fr["frame_number"], last), f"sequence_img_{fr['frame_number']:05d}"
            if not all(getattr(a, "has_image", lambda _: True)(t) for a in mods.values()):
                continue  # a camera rendered at keyframes only (rerender --every): the frames with images
            if "rgb" in mods:
                Image.fromarray(np.asarray(mods["rgb"][t])).save(folder / f"{name}.jpg", quality=_JPEG_QUALITY)
            if "segmentation" in mods:
                (folder / "segmentation").mkdir(exist_ok=True)
                colour = colour_segmentation(mods["segmentation"][t], unit.num_objects)
                Image.fromarray(colour).save(folder / "segmentation" / f"{name}.png", compress_level=3)
            if "depth" in mods:
                save_depth(folder / "depth" / f"{name}.png", mods["depth"][t])
    if unit.previews and "rgb" in mods:
        stream = mods["rgb"]
        rgb = stream.stored() if getattr(stream, "frames", None) is not None else stream[:]  # keyframes: a flip-book
        h, w = rgb.shape[1] // 2 * 2, rgb.shape[2] // 2 * 2
        with VideoWriter(folder / "preview.mp4", w, h, unit.fps, "libx264", crf=23, gop=unit.fps) as vw:
            vw.write(rgb[:, :h, :w])
    recorded, computed = sample_hd_pick_order(frames, effector)
    return ep.num_frames, recorded == computed


def _export_scene_images(root: Path, tmp: Path, scene: SceneAnnotation) -> None:
    stem, new = Path(scene["image_filename"]).stem, scene_stem(int(scene["image_index"]))
    for sub, suffix in (("images", ".png"), ("depth", ".png"), ("depth", ".npy")):
        src = root / sub / f"{stem}{suffix}"
        if src.exists():
            (tmp / sub).mkdir(exist_ok=True)
            shutil.copyfile(src, tmp / sub / f"{new}{suffix}")
    seg = root / "segmentation" / f"{stem}.png"
    if seg.exists():
        (tmp / "segmentation").mkdir(exist_ok=True)
        colour = colour_segmentation(read_segmentation(seg), len(scene["objects"]))
        Image.fromarray(colour).save(tmp / "segmentation" / f"{new}.png", compress_level=3)


def export_samplehd(root: str | Path, out: str | Path, images: bool = True, previews: bool = False,
                    camera: str | None = None, backend: Backend | None = None,
                    progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Write SAMPLE-HD's layout of a complete dataset into ``out`` (a temporary folder, renamed).

    Args:
        root: the samplehd dataset.
        out: the new folder (must not exist or be empty).
        images: write per-frame images (when the episodes store images).
        previews: write ``preview.mp4`` per sequence (H.264 of the camera's RGB).
        camera: the stored camera whose images become the sequence images (default: ``scene``,
            else the first stored one).
        backend: where sequences are written (default: in this process).
        progress: ``progress(done, total)`` per sequence.

    Returns:
        ``{scenes, instructions, sequences, frames, left_out, pick_order, pick_order_differs}``;
        ``left_out`` counts the instructions not exported, by reason; ``pick_order`` is the source
        dataset's ``paths.planner.order``; ``pick_order_differs`` counts the sequences whose recorded
        pick order is not the one SAMPLE-HD's preprocessing computes (:func:`sample_hd_pick_order`;
        0 for a dataset made with ``order: nearest``, as the sample-hd preset does).

    Raises:
        DatasetError: unfinished dataset, non-empty ``out`` or a camera that no episode stores.
    """
    reader, out = export_source(root, out)
    root = Path(root)
    fps = int(round(float(reader.config.get("paths", {}).get("control_hz", 20.0))))
    order = str(reader.config.get("paths", {}).get("planner", {}).get("order", "instruction"))
    base = LAYOUT.robot_base_position
    stored = sorted({c for e in range(len(reader)) for c in reader.episode_meta(e).images})
    if images and not stored:
        with dataset_lock(reader.root, shared=True):  # a dataset being written says so first (it may get images)
            pass
        raise DatasetError(f"{root}: its episodes store no images (a states-only dataset), and SAMPLE-HD's sequences "
                           f"are images; render them first (samplehd rerender {root} --cameras scene) or export "
                           f"without them (`no_images`)", field="images")
    if camera is not None and camera not in stored:
        raise DatasetError(f"camera={camera}: not stored in {root}; stored cameras: {', '.join(stored) or 'none'}",
                           field="camera")
    cam = camera or ("scene" if "scene" in stored else (stored[0] if stored else None))
    scenes = {int(s["image_index"]): _scene_doc(s, base) for s in reader.scenes}
    programs, unity, chosen = [], [], []
    left_out: Counter[str] = Counter()
    for k in range(len(reader)):
        inst = reader.instruction(k)
        if inst["family"] not in SAMPLE_HD_FAMILIES:
            left_out[f"family {inst['family']} (not one of SAMPLE-HD's)"] += 1
            continue
        tokens = str(inst["program_sequence"]).split()
        src_scene = reader.scene(int(inst["image_index"]))
        doc = scenes[int(inst["image_index"])]
        if _band_mismatch(tokens, [list(o.get("table_part") or []) for o in src_scene["objects"]],
                          [o["table_part"] for o in doc["objects"]]):
            left_out["filter_table over an object in the neutral band"] += 1
            continue
        image = doc["image_filename"]
        programs.append({
            "instruction_idx": k, "image_index": int(inst["image_index"]), "image_filename": image,
            "split": inst.get("split"), "instruction": inst["instruction"], "program_sequence": tokens,
            "task": _original_task(inst), "task_id": inst["family"], "family": inst["family"],
            "template_filename": inst.get("template_filename"), "template_index": inst.get("template_index"),
            "program": inst.get("program"),
        })
        unity.append({"image_filename": image, "image_index": int(inst["image_index"]), "instruction_idx": k,
                      "unity_program": unity_program(inst)})
        chosen.append(k)
    info = {"source": "samplehd", "version": reader.info.get("package_version"),
            "families": list(SAMPLE_HD_FAMILIES)}
    with staged_directory(out, source=reader.root) as tmp:
        for sub in ("images", "scenes", "instructions", "sequences"):
            (tmp / sub).mkdir(parents=True, exist_ok=True)
        for s in reader.scenes:
            doc = scenes[int(s["image_index"])]
            (tmp / "scenes" / f"{scene_stem(int(s['image_index']))}.json").write_text(json.dumps(doc))
            _export_scene_images(root, tmp, s)
        (tmp / "instructions" / "instructions_program.json").write_text(
            json.dumps({"info": info, "instructions": programs}))
        (tmp / "instructions" / "instructions_unityGT_filtered.json").write_text(
            json.dumps({"info": info, "instructions": unity}))
        units = [_SequenceUnit(str(reader.episode_path(k)), str(tmp), k,
                               len(reader.scene(int(reader.instruction(k)["image_index"]))["objects"]),
                               cam, images, previews, fps, tuple(float(v) for v in base)) for k in chosen]
        frames = other_order = 0
        for done, (_, (n, same)) in enumerate((backend or Backend()).map(_export_sequence, iter(units)), 1):
            frames += n
            other_order += int(not same)
            if progress:
                progress(done, len(units))
        summary = {"scenes": len(reader.scenes), "instructions": len(programs), "sequences": len(units),
                   "frames": frames, "left_out": dict(left_out), "pick_order": order,
                   "pick_order_differs": other_order}
        (tmp / "info.json").write_text(json.dumps({"layout": "SAMPLE-HD", "fps": fps, "camera": cam,
                                                   **info, **summary}, indent=1))
    return summary
