"""One contact sheet per disturbance kind of a dataset made with ``--disturb``: eight frames of its first
episode of that kind (recovered where one is), from just before the disturbance to the end.

    python scripts/disturbance_sheets.py DATASET OUT_DIR [KIND ...]

Frames: before, the disturbance's first and last frame (at least 4 frames on), the frame the oracle noticed
the failure, three frames of the recovery (start, middle, end) and the final frame; 480 x 270, operator
camera, fast preset.
"""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import json
import sys
from pathlib import Path

from PIL import Image

from samplehd.dataset.container import read_episode
from samplehd.record.disturbances import DISTURBANCE_KINDS
from samplehd.render.contact_sheet import contact_sheet
from samplehd.render.image_spec import ImageSpec
from samplehd.render.states import render_states
from samplehd.scene.spec import SceneSpec, compile_scene


def picks(label: dict, frames: int) -> list[tuple[int, str]]:
    """(frame, caption) of the sheet's tiles."""
    f, last = label["frame"], label["last_frame"]
    first, end = label["recovery_first"], label["recovery_last"]
    out = [(max(0, f - 5), "before"), (f, f"{label['kind']} starts"),
           (max(last, f + 4), f"{label['kind']} ends" if last > f else "4 frames later")]
    if label["noticed_frame"] >= 0:
        out.append((label["noticed_frame"], f"noticed: {label['failure']}"))
    if first >= 0:
        span = end - first
        out += [(first, "recovery starts"), (first + span // 2, "recovery"), (end, "recovery ends")]
    out.append((frames - 1, f"final: {label['outcome']}"))
    tiles = sorted(((min(max(0, t), frames - 1), caption) for t, caption in out), key=lambda tile: tile[0])
    return [tile for k, tile in enumerate(tiles) if k == 0 or tile[0] != tiles[k - 1][0]]


def main(argv: list[str]) -> None:
    root, out = Path(argv[0]), Path(argv[1])
    kinds = argv[2:] or list(DISTURBANCE_KINDS)
    info = json.loads((root / "info.json").read_text())
    scenes = {s["image_index"]: s for s in json.loads((root / "scenes.json").read_text())["scenes"]}
    physics_hz = float(info["config"]["paths"]["physics_hz"])
    out.mkdir(parents=True, exist_ok=True)
    for kind in kinds:
        entries = [e for e in info["episodes"] if e.get("disturbance") == kind]
        entries.sort(key=lambda e: e["outcome"] != "recovered")
        if not entries:
            print(f"{kind}: no episode")
            continue
        entry = entries[0]
        ep = read_episode(root / entry["file"], images="none")
        label = ep.info["disturbance"]
        model, _ = compile_scene(SceneSpec.from_dict(scenes[ep.scene_index]["spec"]), 1.0 / physics_hz)
        tiles = picks(label, ep.num_frames)
        images = render_states(model, ep.frames, ImageSpec(480, 270, "fast", ("operator",), ("rgb",)),
                               [t for t, _ in tiles])
        sheet = contact_sheet(list(images["operator"]["rgb"]), 4, [f"{t}: {c}" for t, c in tiles])
        path = out / f"disturbance_{kind}.png"
        Image.fromarray(sheet).save(path)
        print(f"{kind}: {entry['file']} ({ep.family}, {label['outcome']}) -> {path}")


if __name__ == "__main__":
    main(sys.argv[1:])
