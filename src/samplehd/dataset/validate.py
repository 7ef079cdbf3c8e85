"""Check a dataset directory against its own metadata.

Every problem is collected (never raised) as one line naming the file; an empty list means the
dataset is complete and consistent: info.json, scenes.json, instructions.json and every episode file
(present, size and SHA-256 as recorded, readable, frame fields with the right shapes and dtypes,
images with the recorded cameras, modalities and per-camera resolution).
"""

from __future__ import annotations

import fcntl
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from PIL import Image

from samplehd.catalogue.loader import CATALOGUES, LEGACY_CATALOGUE, load_catalogue
from samplehd.dataset.config import GenerateConfig
from samplehd.dataset.container import camera_settings, read_episode
from samplehd.dataset.layout import (
    EPISODE_DIR,
    FORMAT_VERSION,
    INFO_FILE,
    INSTRUCTIONS_FILE,
    SCENE_DIR,
    SCENES_FILE,
    DatasetInfo,
    InfoEpisode,
    is_temporary,
    scene_image_files,
)
from samplehd.dataset.lock import lock_holder
from samplehd.errors import ConfigError, DatasetError
from samplehd.fileio import file_sha256, not_a_regular_file, resolve_path
from samplehd.record.disturbances import LABEL_FIELDS
from samplehd.render.keyframes import keyframe_indices
from samplehd.scene.annotate import SceneAnnotation

__all__ = ["known_classes", "validate_dataset", "validate_episode_file", "validate_scene_files",
           "validate_stored_config"]


def _load(path: Path, problems: list[str]) -> Any:
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        problems.append(f"{path}: missing")
    except (OSError, ValueError) as exc:
        problems.append(f"{path}: unreadable or not JSON ({exc})")
    return None


def validate_episode_file(path: Path, entry: InfoEpisode, render: dict[str, Any] | None,
                          deep: bool = False) -> list[str]:
    """Problems of one episode file compared with its ``info.json`` entry and the render settings
    (``info.json``'s ``render``: every camera with its own resolution and modalities, see
    :func:`samplehd.dataset.container.camera_settings`)."""

    problems: list[str] = []
    why = not_a_regular_file(path)
    if why is not None:
        return [f"{path}: is {why}, not an episode file"]
    if not path.exists():
        return [f"{path}: missing"]
    size = path.stat().st_size
    if entry.get("size", -1) >= 0 and size != entry["size"]:
        problems.append(f"{path}: size {size} bytes, info.json says {entry['size']} (truncated or modified)")
    if entry.get("sha256") and file_sha256(path) != entry["sha256"]:
        problems.append(f"{path}: SHA-256 differs from info.json (corrupted or modified)")
    try:
        ep = read_episode(path, images="none")
    except DatasetError as exc:
        return [*problems, str(exc)]
    if ep.num_frames != entry.get("num_frames", ep.num_frames):
        problems.append(f"{path}: {ep.num_frames} frames, info.json says {entry['num_frames']}")
    if ep.scene_index != entry.get("scene_index", ep.scene_index):
        problems.append(f"{path}: scene_index {ep.scene_index}, info.json says {entry['scene_index']}")
    if ep.seed != entry.get("seed", ep.seed):
        problems.append(f"{path}: seed {ep.seed}, info.json says {entry['seed']}")
    label = ep.info.get("disturbance")
    if label is not None:
        problems.extend(_disturbance_problems(path, ep, label, entry))
    elif not ep.success:
        problems.append(f"{path}: episode is not marked successful")
    for key in ("qpos", "qvel", "joint_pos", "object_pos", "steering"):
        if not np.all(np.isfinite(ep.frames[key])):
            problems.append(f"{path}: frames/{key} has non-finite values")
    try:
        want = camera_settings(render)
    except DatasetError as exc:
        return [*problems, f"info.json render: {exc}"]
    try:
        with h5py.File(path, "r") as f:
            has = "images" in f
            if want:
                if not has:
                    problems.append(f"{path}: no images, but info.json lists cameras {', '.join(want)}")
                else:
                    try:
                        stored = camera_settings(json.loads(f["images"].attrs["render"]))
                    except (KeyError, ValueError, DatasetError) as exc:
                        stored = None
                        problems.append(f"{path}: images/ render attribute unreadable: {exc}")
                    if stored is not None and stored != want:
                        problems.append(f"{path}: images/ render settings {stored} differ from info.json's {want}")
                    for cam, s in want.items():
                        h, w = s["height"], s["width"]
                        # Keyframes only (rerender --every/--subtask-ends): the recorded frames are the
                        # ones the settings choose, and each stream holds one image per recorded frame.
                        chosen = keyframe_indices(ep.num_frames, s.get("every", 1), ep.frames["subtask_index"],
                                                  bool(s.get("subtask_ends", False)))
                        group = f["images"].get(cam)
                        recorded = (np.asarray(group.attrs["frame_index"]) if group is not None
                                    and "frame_index" in group.attrs else np.arange(ep.num_frames))
                        if not np.array_equal(recorded, chosen):
                            problems.append(f"{path}: images/{cam} has images at {len(recorded)} frames, its "
                                            f"settings choose {len(chosen)}")
                        for mod in s["modalities"]:
                            key = f"images/{cam}/{mod}"
                            if key not in f:
                                problems.append(f"{path}: {key} missing")
                                continue
                            ds = f[key]
                            n = len(recorded)
                            shape = (n, h, w, 3) if mod == "rgb" else (n, h, w)
                            if tuple(ds.shape) != shape:
                                problems.append(f"{path}: {key} has shape {tuple(ds.shape)}, expected {shape}")
                            elif deep:
                                for t in range(ds.shape[0]):
                                    ds[t]
    except (OSError, RuntimeError, KeyError) as exc:
        problems.append(f"{path}: cannot read images: {exc}")
    return problems


def _disturbance_problems(path: Path, ep: Any, label: dict[str, Any], entry: InfoEpisode) -> list[str]:
    """Problems of a disturbed episode's labels: a failure only as a failed recovery, the flags as the label says."""
    problems: list[str] = []
    if not ep.success and label.get("outcome") != "failed":
        problems.append(f"{path}: episode is not marked successful, but its disturbance label says "
                        f"{label.get('outcome')!r}")
    if bool(label.get("success")) != ep.success or entry.get("success", ep.success) != ep.success:
        problems.append(f"{path}: success {ep.success} differs from its disturbance label or info.json")
    t = ep.num_frames
    for key in LABEL_FIELDS:
        if key not in ep.frames:
            problems.append(f"{path}: frames/{key} missing (a disturbed episode has it)")
    if problems:
        return problems
    active, recovery = ep.frames["disturbance_active"], ep.frames["recovery"]
    want = np.zeros(t, np.int8)
    if label["frame"] >= 0:
        want[label["frame"]:label["last_frame"] + 1] = 1
    if not np.array_equal(active, want):
        problems.append(f"{path}: frames/disturbance_active does not span frames {label['frame']}.."
                        f"{label['last_frame']} of its label")
    want = np.zeros(t, np.int8)
    if label["recovery_first"] >= 0:
        want[label["recovery_first"]:label["recovery_last"] + 1] = 1
    if not np.array_equal(recovery, want):
        problems.append(f"{path}: frames/recovery does not span frames {label['recovery_first']}.."
                        f"{label['recovery_last']} of its label")
    return problems


def _writer_running(root: Path) -> str | None:
    """``process PID`` (or ``another process``) when a command holds the dataset's lock to change it
    (generate, rerender: :mod:`samplehd.dataset.lock`), else None. Only asked, never held."""
    try:
        fd = os.open(root, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        pid = lock_holder(fd)
        return f"process {pid}" if pid else "another process"
    finally:
        os.close(fd)  # closing releases the shared lock taken to ask
    return None


def validate_stored_config(root: Path, info: DatasetInfo) -> list[str]:
    """Problems of the generation config and catalogue recorded in ``info.json`` (what the trainers and
    the replay build their environment from): the config must be one this samplehd reads, the catalogue
    a built-in one."""
    problems: list[str] = []
    config = info.get("config")
    if isinstance(config, dict):
        try:
            GenerateConfig.from_dict(config)
        except ConfigError as exc:
            problems.append(f"{root / INFO_FILE}: {exc}")
    recorded = info.get("catalogue")
    if isinstance(recorded, dict) and recorded.get("name") not in CATALOGUES:
        problems.append(f"{root / INFO_FILE}: catalogue.name={recorded.get('name')!r}: valid: {', '.join(CATALOGUES)}")
    return problems


_MATRIX_SHAPES = {"intrinsics": (3, 3), "extrinsics": (4, 4)}


def _camera_problems(where: str, camera: Any) -> list[str]:
    if not isinstance(camera, dict):
        return [f"{where}: field 'camera' missing or not an object (needs width, height, intrinsics, extrinsics)"]
    problems = []
    for key in ("width", "height"):
        value = camera.get(key)
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            problems.append(f"{where}: camera.{key}={value!r}: valid: a positive integer [px]")
    for key, shape in _MATRIX_SHAPES.items():
        try:
            matrix = np.asarray(camera.get(key), dtype=float)
        except (TypeError, ValueError):
            matrix = np.zeros(0)
        if matrix.shape != shape or not np.all(np.isfinite(matrix)):
            problems.append(f"{where}: camera.{key}: valid: a {shape[0]}x{shape[1]} matrix of finite numbers")
    return problems


# The PNG modes the scene writer uses (render.image_io): RGB, depth in uint16 millimetres, instance ids in
# 8 or 16 bits.
_PNG_MODES: dict[str, tuple[tuple[str, ...], str]] = {
    "rgb": (("RGB",), "8-bit RGB"),
    "depth": (("I;16", "I;16B", "I;16L", "I"), "16-bit grey millimetres"),
    "segmentation": (("L", "I;16", "I;16B", "I;16L", "I"), "8- or 16-bit instance ids"),
}


def _image_problem(path: Path, camera: dict[str, Any], what: str) -> str | None:
    """Decode one scene image file; the problem or None."""
    size = (camera.get("width"), camera.get("height"))
    try:
        if path.suffix == ".npy":
            array = np.load(path, allow_pickle=False)
            if array.shape != size[::-1] or array.dtype.kind != "f":
                return (f"{path}: {what} of shape {array.shape} and dtype {array.dtype}, the scene camera's is "
                        f"{size[1]}x{size[0]} float")
            return None
        with Image.open(path) as image:
            image.load()
            if image.size != size:
                return (f"{path}: {what} of {image.size[0]}x{image.size[1]} px, the scene camera's is "
                        f"{size[0]}x{size[1]}")
            modes, kind = _PNG_MODES[what]
            if image.mode not in modes:
                return f"{path}: {what} PNG of mode {image.mode}; valid: {kind} ({', '.join(modes)})"
    except (OSError, ValueError, SyntaxError, Image.DecompressionBombError) as exc:
        if path.suffix == ".npy":
            return f"{path}: {what} is not a NumPy .npy array (expected {size[1]}x{size[0]} float32 metres)"
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return f"{path}: {what} cannot be decoded as a PNG ({reason[:120]})"
    return None


def known_classes(info: DatasetInfo) -> tuple[str, ...] | None:
    """The object classes a dataset's scenes may hold: its built-in catalogue's (the one ``info.json``
    records, as :attr:`DatasetReader.catalogue <samplehd.dataset.reader.DatasetReader.catalogue>` reads
    it) and the imported classes the stored config names (``scene.classes``, ``scene.menu_overrides``);
    None when that is no built-in catalogue (a problem :func:`validate_stored_config` reports)."""
    config = info.get("config")
    scene = config.get("scene") if isinstance(config, dict) else None
    scene = scene if isinstance(scene, dict) else {}
    recorded = info.get("catalogue")
    name = recorded.get("name") if isinstance(recorded, dict) and isinstance(recorded.get("name"), str) \
        else scene.get("catalogue", LEGACY_CATALOGUE)
    if not isinstance(name, str) or name not in CATALOGUES:
        return None
    named = [n for n in (*(scene.get("classes") or ()), *(scene.get("menu_overrides") or {})) if isinstance(n, str)]
    builtin = tuple(load_catalogue(name=name).classes)
    return builtin + tuple(n for n in named if n not in builtin)


def _class_problems(where: str, scene: SceneAnnotation, valid: tuple[str, ...]) -> list[str]:
    """An object of the scene (``objects[k].shape`` or ``spec.objects[k].instance.class_name``) of a class
    not in ``valid``: the first one, in one line."""
    spec = scene.get("spec")
    placed = spec.get("objects") if isinstance(spec, dict) else None
    named = [(f"objects[{k}].shape", o.get("shape")) for k, o in enumerate(scene.get("objects") or [])
             if isinstance(o, dict)]
    named += [(f"spec.objects[{k}].instance.class_name", (o.get("instance") or {}).get("class_name"))
              for k, o in enumerate(placed or []) if isinstance(o, dict) and isinstance(o.get("instance"), dict)]
    for field, value in named:
        if value is not None and value not in valid:
            return [f"{where}: {field}={value!r}: not a class of the dataset's catalogue or config; "
                    f"valid: {', '.join(valid)}"]
    return []


def validate_scene_files(root: Path, scenes: list[SceneAnnotation], deep: bool = False,
                         info: DatasetInfo | None = None) -> list[str]:
    """Problems of the scenes' camera records and image files (``images/``, ``depth/``,
    ``segmentation/``: what the scene trainers and the exporters read): each present, and with ``deep``
    decoded and of the size of the scene's camera; with ``info`` (the dataset's ``info.json``) also each
    object's class, one of :func:`known_classes`."""
    problems: list[str] = []
    valid = known_classes(info) if info is not None else None
    for s in scenes:
        where = f"{root / SCENES_FILE}: scene {s.get('image_index')}"
        if valid is not None:
            problems.extend(_class_problems(where, s, valid))
        camera_problems = _camera_problems(where, s.get("camera"))
        problems.extend(camera_problems)
        name = s.get("image_filename")
        if not isinstance(name, str) or not name:
            problems.append(f"{where}: field 'image_filename' missing")
            continue
        for what, path in scene_image_files(root, name).items():
            if not path.is_file():
                problems.append(f"{path}: missing (the scene's {what.replace('_png', '')} image)")
            elif deep and not camera_problems:
                problem = _image_problem(path, s["camera"], what.replace("_png", ""))
                if problem:
                    problems.append(problem)
    return problems


def validate_dataset(root: str | Path, deep: bool = False,
                     on_episode: Callable[[int, int], None] | None = None) -> tuple[list[str], dict[str, int]]:
    """Check a whole dataset.

    Args:
        root: the dataset directory.
        deep: also decode every image chunk (the SHA-256 check already covers file integrity) and every
            scene image (images/, depth/, segmentation/, checked against the scene's camera).
        on_episode: progress callback ``(done, total)``.

    Returns:
        (problems, counts) where counts has episodes and frames checked.

    Raises:
        DatasetError: ``root`` is no dataset (not a folder, no info.json) or one of a format this
            samplehd cannot check.
    """
    root = Path(root)
    problems: list[str] = []
    resolve_path(root)  # a loop of symbolic links is said as one
    if not root.is_dir():
        raise DatasetError(f"{root}: {'is a file' if root.exists() else 'does not exist'}; give a dataset folder")
    if not (root / INFO_FILE).is_file():
        raise DatasetError(f"{root}: not a samplehd dataset ({INFO_FILE} is missing)")
    info = _load(root / INFO_FILE, problems)
    if isinstance(info, dict) and info.get("format_version") != FORMAT_VERSION:
        raise DatasetError(f"{root / INFO_FILE}: format_version {info.get('format_version')!r} is not one this "
                           f"samplehd reads (valid: {FORMAT_VERSION!r}); use the samplehd version that wrote it")
    if not isinstance(info, dict):
        return problems, {}
    writer = _writer_running(root)  # what a running writer leaves half-done is no problem of the data
    if writer is not None:
        what = "a rerender" if isinstance(info.get("rerender"), dict) else \
            "generate" if info.get("status") != "complete" else "a samplehd command"
        raise DatasetError(f"{root}: {what} is running ({writer} holds the dataset); validate it when that has "
                           f"finished")
    if info.get("status") != "complete":
        problems.append(f"{root / INFO_FILE}: status {info.get('status')!r}: generation has not finished "
                        f"(run samplehd generate --resume)")
        return problems, {}
    if isinstance(info.get("rerender"), dict):
        r = info["rerender"]
        problems.append(f"{root / INFO_FILE}: a rerender stopped after {r.get('done')} of {r.get('episodes')} "
                        "episodes; run the same rerender again to finish it")
    for key in ("versions", "config", "episodes", "counts", "seeds"):
        if key not in info:
            problems.append(f"{root / INFO_FILE}: field {key!r} missing")
    problems.extend(validate_stored_config(root, info))
    episodes = list(info.get("episodes", []))
    counts = info.get("counts", {})
    scenes_doc = _load(root / SCENES_FILE, problems)
    scenes = list(scenes_doc.get("scenes", [])) if isinstance(scenes_doc, dict) else []
    if scenes_doc is not None:
        idx = [s.get("image_index") for s in scenes]
        if idx != list(range(len(scenes))):
            problems.append(f"{root / SCENES_FILE}: image_index values are not 0..{len(scenes) - 1} in order")
        if counts.get("scenes") != len(scenes):
            problems.append(f"{root / SCENES_FILE}: {len(scenes)} scenes, info.json says {counts.get('scenes')}")
        problems.extend(validate_scene_files(root, scenes, deep, info))
        for s in scenes:
            stem = Path(str(s.get("image_filename", ""))).stem
            if not (root / SCENE_DIR / f"{stem}.json").exists():
                problems.append(f"{root / SCENE_DIR / stem}.json: missing")
            if "spec" not in s:
                problems.append(f"{root / SCENES_FILE}: scene {s.get('image_index')}: field 'spec' missing")
    inst_doc = _load(root / INSTRUCTIONS_FILE, problems)
    insts = list(inst_doc.get("instructions", [])) if isinstance(inst_doc, dict) else []
    if inst_doc is not None:
        if len(insts) != len(episodes):
            problems.append(f"{root / INSTRUCTIONS_FILE}: {len(insts)} instructions, info.json lists "
                            f"{len(episodes)} episodes")
        for k, (inst, ep) in enumerate(zip(insts, episodes, strict=False)):
            if inst.get("instruction_index") != k:
                problems.append(f"{root / INSTRUCTIONS_FILE}: entry {k} has instruction_index "
                                f"{inst.get('instruction_index')}")
            if inst.get("file") != ep.get("file") or inst.get("image_index") != ep.get("scene_index"):
                problems.append(f"{root / INSTRUCTIONS_FILE}: entry {k} does not match info.json episode {k}")
            if not 0 <= int(inst.get("image_index", -1)) < max(len(scenes), 1):
                problems.append(f"{root / INSTRUCTIONS_FILE}: entry {k} points to scene {inst.get('image_index')}")
    if counts.get("episodes") != len(episodes):
        problems.append(f"{root / INFO_FILE}: counts.episodes {counts.get('episodes')} but {len(episodes)} listed")
    render = info.get("render")
    listed = set()
    frames = 0
    for k, entry in enumerate(episodes):
        path = root / str(entry.get("file", ""))
        listed.add(path.name)
        if entry.get("instruction_index") != k:
            problems.append(f"{root / INFO_FILE}: episodes[{k}] has instruction_index {entry.get('instruction_index')}")
        problems.extend(validate_episode_file(path, entry, render, deep))
        frames += int(entry.get("num_frames", 0))
        if on_episode:
            on_episode(k + 1, len(episodes))
    if sum(int(e.get("num_frames", 0)) for e in episodes) != counts.get("frames"):
        problems.append(f"{root / INFO_FILE}: counts.frames {counts.get('frames')} differs from the episode sum")
    folder = root / EPISODE_DIR
    for p in sorted(folder.iterdir()) if folder.is_dir() else []:
        if is_temporary(p.name):
            problems.append(f"{p}: leftover temporary file (an interrupted write; run generate --resume)")
        elif p.name not in listed:
            problems.append(f"{p}: not listed in info.json")
    return problems, {"episodes": len(episodes), "frames": frames, "scenes": len(scenes)}
