"""Helpers of the dataset tests (a uniquely named module: several test folders have a conftest)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

# The tiny preset cut to 2 scenes × 2 instruction candidates, states only: a few seconds of real
# planning and physics. `samplehd generate --preset tiny --config micro.json` makes the same dataset.
MICRO: dict[str, Any] = {
    "num_scenes": 2,
    "seed": 0,
    "test_every": 2,
    "scene": {"min_objects": 3, "max_objects": 3},
    "instructions": {"per_scene": 2},
    "render": {"mode": "none"},
}


def micro_config(**render: Any):  # noqa: ANN201
    from samplehd.dataset.config import GenerateConfig, preset_config

    d = json.loads(json.dumps(MICRO))
    d["render"].update(render)
    return GenerateConfig.from_dict(d, base=preset_config("tiny"))


def micro_config_file(folder: Path) -> Path:
    path = folder / "micro.json"
    path.write_text(json.dumps(MICRO))
    return path


def fingerprint(root: Path) -> dict[str, Any]:
    """What must be identical between two runs: scenes, instructions and every episode file's bytes."""
    info = json.loads((root / "info.json").read_text())
    return {
        "scenes": (root / "scenes.json").read_text(),
        "instructions": (root / "instructions.json").read_text(),
        "candidates": (root / "candidates.json").read_text(),
        "episodes": [(e["file"], e["num_frames"], e["sha256"]) for e in info["episodes"]],
        "counts": info["counts"],
    }
