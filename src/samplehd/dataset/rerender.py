"""Add or replace every episode's images from its stored physics states, without re-simulating.

Each episode file is rewritten atomically with the new ``/images``. By default the new images replace
all the file's images; with ``add=True`` the file's other cameras are kept (their stored chunks are
copied unchanged) and a camera + modality rendered again is overwritten, so cameras can have
different resolutions and presets. The file's ``/images`` ``render`` attribute and ``info.json``'s
``render`` describe the result per camera (``per_camera``). An episode whose file already carries
the requested per-camera settings is skipped, so running the same command again after a crash
resumes where it stopped. ``info.json`` gets the new ``render`` settings and the new sizes and digests.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from samplehd.dataset.container import (
    camera_settings,
    describe_settings,
    merge_camera_settings,
    read_meta,
    render_record,
)
from samplehd.dataset.layout import EPISODE_DIR, INFO_FILE, RUNS_FILE
from samplehd.dataset.lock import dataset_lock
from samplehd.dataset.progress import Progress
from samplehd.dataset.reader import DatasetReader
from samplehd.dataset.render import RenderConfig, check_cameras
from samplehd.dataset.work import RenderUnit, run_render_unit
from samplehd.errors import DatasetError
from samplehd.fileio import file_sha256, write_json_atomic
from samplehd.render.image_spec import PRESET_NAMES
from samplehd.scene.spec import SceneSpec
from samplehd.workers import Backend

__all__ = ["rerender_dataset"]


def rerender_dataset(root: str | Path, render: RenderConfig, backend: Backend | None = None,
                     progress: Progress | None = None, add: bool = False) -> dict[str, Any]:
    """Render every episode of a dataset with ``render``.

    Args:
        root: the dataset directory (generation must be complete).
        render: cameras, modalities, resolution and preset (mode fast or hd).
        backend: where units run (default: in this process).
        progress: progress receiver (stage ``rerender``).
        add: keep the episodes' other cameras and modalities (default: replace all images).

    Returns:
        ``{episodes, rendered, skipped, frames, seconds, add, render}`` (``render``: the new
        ``info.json`` ``render``).

    Raises:
        DatasetError: not a complete dataset, conflicting settings (see
            :func:`~samplehd.dataset.container.merge_camera_settings`), episodes whose images differ before an add (an
            interrupted different rerender), or a file cannot be written.
        ConfigError: unknown camera.
    """
    if not render.enabled:
        raise DatasetError(f"rerender needs a render preset ({', '.join(PRESET_NAMES[:-1])} or {PRESET_NAMES[-1]}), "
                           "not 'none'")
    check_cameras(render)
    root = Path(root)
    DatasetReader(root)  # a dataset folder (a clear refusal before the lock is tried)
    with dataset_lock(root):  # for the whole run: no other command changes or exports it meanwhile
        return _rerender(root, render, backend, progress, add)


def _rerender(root: Path, render: RenderConfig, backend: Backend | None, progress: Progress | None,
              add: bool) -> dict[str, Any]:
    reader = DatasetReader(root)  # read again under the lock
    if not reader.complete:
        raise DatasetError(f"{root}: generation has not finished; finish it first "
                           "(generate into it again with `resume`)")
    reader.check_intact(verify=True)  # every episode read and checked before any is rewritten
    # Episodes and info.json are replaced by renames: their folders must be writable, and the files
    # themselves not immutable (a rename onto an immutable file fails, even for root).
    episodes = [reader.episode_path(i) for i in range(len(reader.episodes))]
    targets = [root, root / EPISODE_DIR, root / INFO_FILE, *episodes]
    for path in targets:
        if not os.access(path, os.W_OK):
            raise DatasetError(f"{path}: not writable (read-only or immutable); nothing was changed; make it "
                               f"writable or rerender a copy")
    backend = backend or Backend()
    progress = progress or Progress()
    t0 = time.perf_counter()
    scenes = {int(s["image_index"]): s["spec"] for s in reader.scenes}
    physics_hz = float(reader.config.get("paths", {}).get("physics_hz", 500.0))
    units: list[RenderUnit] = []
    skipped = 0
    result: dict[str, dict[str, Any]] | None = None
    first = ""
    for i, e in enumerate(reader.episodes):
        path = reader.episode_path(i)
        # An unreadable episode stops the command before any episode is re-rendered.
        old = camera_settings(read_meta(path)["render"])
        try:
            want = merge_camera_settings(old or {}, render, add)
        except DatasetError as exc:
            raise DatasetError(f"{path}: {exc}") from None
        if result is None:
            result, first = want, path.name
        elif want != result:
            raise DatasetError(
                f"{path}: would hold cameras {_cameras(want)} but {first} {_cameras(result)}: the episodes "
                f"differ (an interrupted rerender with other settings?); finish that rerender first (run it "
                f"again) or re-render without `add`")
        if old == want:
            skipped += 1
        else:
            scene = SceneSpec.from_dict(scenes[e.scene_index])
            units.append(RenderUnit(str(path), scene, physics_hz, render, replace=not add))
    progress.stage("rerender", len(reader.episodes), skipped)
    # info.json follows the disk at every moment: each episode is replaced atomically by its unit, and
    # its size and digest are written to info.json (atomically) as soon as it is done; while the
    # command runs, info.json says so (``rerender``), so an interrupted run is visible and finished
    # by running the same command again.
    info = json.loads((root / INFO_FILE).read_text())
    by_file = {str((root / e["file"]).resolve()): e for e in info["episodes"]}
    if result is None:  # no episodes: describe what they would hold
        result = merge_camera_settings(camera_settings(info.get("render")), render, add)
    record = render_record(result)
    info["rerender"] = {"render": record, "episodes": len(units), "done": 0}
    if units:
        write_json_atomic(root / INFO_FILE, info, indent=1)
    frames = 0
    for _, res in backend.map(run_render_unit, iter(units)):
        frames += res.num_frames
        entry = by_file[str(Path(res.path).resolve())]
        entry["size"], entry["sha256"] = res.size, res.sha256
        info["rerender"]["done"] += 1
        write_json_atomic(root / INFO_FILE, info, indent=1)
        progress.advance("rerender", 1, res.num_frames)
    # Refresh sizes and digests of every file (also those finished by an interrupted earlier run).
    for entry in info["episodes"]:
        p = root / entry["file"]
        entry["size"] = p.stat().st_size
        entry["sha256"] = file_sha256(p)
    del info["rerender"]
    info.setdefault("render_history", []).append(info.get("render"))
    info["render"] = record
    write_json_atomic(root / INFO_FILE, info, indent=1)
    seconds = time.perf_counter() - t0
    with open(root / RUNS_FILE, "a", encoding="utf-8") as f:
        f.write(json.dumps({"command": "rerender", "add": add, "render": render.to_dict(),
                            "backend": backend.describe(), "rendered": len(units), "skipped": skipped,
                            "frames": frames, "seconds": round(seconds, 3)}) + "\n")
    return {"episodes": len(reader.episodes), "rendered": len(units), "skipped": skipped, "frames": frames,
            "seconds": seconds, "add": add, "render": record}


def _cameras(settings: Mapping[str, Mapping[str, Any]]) -> str:
    described = [f"{c} ({describe_settings(s)}: {' '.join(s['modalities'])})" for c, s in settings.items()]
    return ", ".join(described) or "none"
