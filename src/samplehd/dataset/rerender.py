"""Add or replace every episode's images from its stored physics states, without re-simulating.

Each episode file is rewritten atomically with the new ``/images``; an episode whose file already
carries the requested render settings is skipped, so running the same command again after a crash
resumes where it stopped. ``info.json`` gets the new ``render`` settings and the new sizes and digests.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from samplehd.dataset.backend import Backend
from samplehd.dataset.generate import Progress
from samplehd.dataset.layout import INFO_FILE, RUNS_FILE
from samplehd.dataset.render import RenderConfig
from samplehd.errors import DatasetError

__all__ = ["rerender_dataset"]


def rerender_dataset(root: str | Path, render: RenderConfig, backend: Backend | None = None,
                     progress: Progress | None = None) -> dict[str, Any]:
    """Render every episode of a dataset with ``render`` (replacing any images it had).

    Args:
        root: the dataset directory (generation must be complete).
        render: cameras, modalities, resolution and preset (mode fast or hd).
        backend: where units run (default: in this process).
        progress: progress receiver (stage ``rerender``).

    Returns:
        ``{episodes, rendered, skipped, frames, seconds}``.

    Raises:
        DatasetError: not a complete dataset, or a file cannot be written.
    """
    from samplehd.dataset.container import read_meta
    from samplehd.dataset.reader import DatasetReader
    from samplehd.dataset.work import RenderUnit, run_render_unit
    from samplehd.scene.generate import write_json_atomic

    if not render.enabled:
        raise DatasetError("rerender needs a render preset (fast or hd), not 'none'")
    from samplehd.dataset.render import check_cameras

    check_cameras(render)
    root = Path(root)
    reader = DatasetReader(root)
    if not reader.complete:
        raise DatasetError(f"{root}: generation has not finished; run samplehd generate --resume first")
    backend = backend or Backend()
    progress = progress or Progress()
    t0 = time.perf_counter()
    scenes = {int(s["image_index"]): s["spec"] for s in reader.scenes}
    physics_hz = float(reader.config.get("paths", {}).get("physics_hz", 500.0))
    want = render.to_dict()
    units, skipped = [], 0
    for e in reader.episodes:
        path = root / e.file
        try:
            done = read_meta(path)["render"] == want
        except DatasetError:
            done = False
        if done:
            skipped += 1
        else:
            units.append(RenderUnit(str(path), scenes[e.scene_index], physics_hz, want))
    progress.stage("rerender", len(reader.episodes), skipped)
    frames = 0
    for _, res in backend.map(run_render_unit, iter(units)):
        frames += int(res["num_frames"])
        progress.advance("rerender", 1, int(res["num_frames"]))
    # Refresh sizes and digests of every file (also those finished by an interrupted earlier run).
    from samplehd.dataset.container import file_digest

    info = json.loads((root / INFO_FILE).read_text())
    for entry in info["episodes"]:
        p = root / entry["file"]
        entry["size"] = p.stat().st_size
        entry["sha256"] = file_digest(p)
    info.setdefault("render_history", []).append(info.get("render"))
    info["render"] = want
    write_json_atomic(root / INFO_FILE, info, indent=1)
    seconds = time.perf_counter() - t0
    with open(root / RUNS_FILE, "a", encoding="utf-8") as f:
        f.write(json.dumps({"command": "rerender", "render": want, "backend": backend.describe(),
                            "rendered": len(units), "skipped": skipped, "frames": frames,
                            "seconds": round(seconds, 3)}) + "\n")
    return {"episodes": len(reader.episodes), "rendered": len(units), "skipped": skipped, "frames": frames,
            "seconds": seconds}
