"""A compact, comparable summary of a generated dataset: the golden fixture of a pure refactoring.

``summarise(out)`` reads what ``samplehd generate`` wrote and keeps everything that must not change
when the code is restructured: the scenes, the instruction candidates and instructions, the counts,
rejections and seeds of ``info.json``, and per episode its attributes and, per per-frame array
(qpos, joints, steering, object poses, subtasks, ...), its dtype, shape and SHA-256 of the bytes
(bitwise). Versions, timings and file checksums (which depend on the HDF5 library) are left out.

Three goldens: ``tiny_seed3`` (the tiny preset), ``crowded_seed6`` (three scenes of six objects,
families balanced: longer paths, more contact), both on the ``procedural`` catalogue, named in their
config files so that they stay the same whatever the default catalogue, and ``tiny_shop_vrb_seed3``
(the tiny preset on the ``shop-vrb`` catalogue, also named: mesh objects, hull contacts). Regenerate a
fixture (only when a change of the data is intended, saying why in the commit)::

    python -m samplehd generate <GOLDENS[name] args> --out OUT_DIR --quiet
    python tests/golden/golden.py OUT_DIR > tests/golden/<name>.json
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path
from typing import Any

import h5py
import numpy as np

HERE = Path(__file__).parent
# name -> the ``samplehd`` arguments that make it; its fixture is ``<name>.json`` beside this file
GOLDENS: dict[str, list[str]] = {
    "tiny_seed3": ["generate", "--preset", "tiny", "--config", str(HERE / "procedural.json"), "--render", "none",
                   "--seed", "3"],
    "crowded_seed6": ["generate", "--preset", "tiny", "--config", str(HERE / "crowded.json"), "--render", "none",
                      "--seed", "6"],
    "tiny_shop_vrb_seed3": ["generate", "--preset", "tiny", "--config", str(HERE / "shop_vrb.json"), "--render",
                            "none", "--seed", "3"],
}
GOLDEN_ARGS = GOLDENS["tiny_seed3"]
FIXTURE = HERE / "tiny_seed3.json"


def fixture(name: str) -> Path:
    """The fixture file of the golden ``name``."""
    return HERE / f"{name}.json"
_INFO_KEYS = ("counts", "target_reached", "rejections", "seeds", "render")
_EPISODE_SKIP = ("sha256", "size")


def _array(a: np.ndarray) -> dict[str, Any]:
    a = np.ascontiguousarray(a)
    return {"dtype": str(a.dtype), "shape": list(a.shape), "sha256": hashlib.sha256(a.tobytes()).hexdigest()}


def _attr(v: Any) -> Any:
    if isinstance(v, bytes):
        v = v.decode()
    if isinstance(v, str):
        try:
            return json.loads(v)
        except ValueError:
            return v
    if isinstance(v, np.generic):
        return v.item()
    return v


def summarise(out: Path) -> dict[str, Any]:
    """The golden summary of the dataset directory ``out``."""
    out = Path(out)
    summary: dict[str, Any] = {}
    for name in ("scenes", "candidates", "instructions"):
        doc = json.loads((out / f"{name}.json").read_text())
        key = "scenes" if name == "scenes" else "instructions"
        summary[name] = doc[key]
    info = json.loads((out / "info.json").read_text())
    summary["info"] = {k: info[k] for k in _INFO_KEYS}
    summary["info"]["episodes"] = [{k: v for k, v in e.items() if k not in _EPISODE_SKIP} for e in info["episodes"]]
    episodes: dict[str, Any] = {}
    for path in sorted((out / "episodes").glob("*.h5")):
        with h5py.File(path, "r") as f:
            episodes[path.name] = {
                "attrs": {k: _attr(v) for k, v in sorted(f.attrs.items())},
                "frames": {k: _array(f["frames"][k][()]) for k in sorted(f["frames"])},
            }
    summary["episodes"] = episodes
    return summary


def differences(expected: Any, actual: Any, where: str = "", limit: int = 20) -> list[str]:
    """Paths where two summaries differ (at most ``limit``)."""
    out: list[str] = []

    def walk(e: Any, a: Any, at: str) -> None:
        if len(out) >= limit:
            return
        if isinstance(e, dict) and isinstance(a, dict):
            for k in sorted(set(e) | set(a), key=str):
                if k not in a or k not in e:
                    out.append(f"{at}/{k}: {'missing' if k not in a else 'unexpected'}")
                else:
                    walk(e[k], a[k], f"{at}/{k}")
        elif isinstance(e, list) and isinstance(a, list) and len(e) == len(a):
            for i, (x, y) in enumerate(zip(e, a, strict=True)):
                walk(x, y, f"{at}[{i}]")
        elif e != a:
            out.append(f"{at}: expected {str(e)[:120]}, got {str(a)[:120]}")

    walk(expected, actual, where)
    return out


if __name__ == "__main__":
    json.dump(summarise(Path(sys.argv[1])), sys.stdout, indent=1, sort_keys=True)
    sys.stdout.write("\n")
