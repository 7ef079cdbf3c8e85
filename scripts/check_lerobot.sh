#!/usr/bin/env bash
# Prove that LeRobot itself loads a samplehd LeRobot export: make a Python 3.12 venv (lerobot >= 0.5
# needs 3.12), install lerobot[dataset]==0.6.1 (pulls torch: ~5.5 GB), and open the export with
# LeRobotDataset(repo_id, root=...). Independent of the Makefile and of `make test`.
#
# usage: scripts/check_lerobot.sh EXPORT_DIR [REPO_ID]
#   env: LEROBOT_VENV (default .venv-lerobot), PYTHON312 (default: pyenv's 3.12.1, else python3.12)
set -euo pipefail
export_dir="${1:?usage: scripts/check_lerobot.sh EXPORT_DIR [REPO_ID]}"
repo_id="${2:-samplehd/dataset}"
venv="${LEROBOT_VENV:-.venv-lerobot}"
py="${PYTHON312:-}"
if [[ -z "$py" ]]; then
  for cand in /root/.pyenv/versions/3.12.1/bin/python3 "$(command -v python3.12 || true)"; do
    if [[ -n "$cand" && -x "$cand" ]]; then py="$cand"; break; fi
  done
fi
[[ -n "$py" ]] || { echo "check_lerobot: no Python 3.12 found (set PYTHON312)" >&2; exit 2; }
if [[ ! -x "$venv/bin/python" ]]; then
  "$py" -m venv "$venv"
  "$venv/bin/python" -m pip install --quiet --upgrade pip
fi
if ! "$venv/bin/python" -c "import lerobot, datasets" 2>/dev/null; then
  "$venv/bin/python" -m pip install --quiet "lerobot[dataset]==0.6.1"
fi
"$venv/bin/python" - "$export_dir" "$repo_id" <<'PY'
import json, sys
from pathlib import Path

from lerobot.datasets.lerobot_dataset import LeRobotDataset

root, repo_id = Path(sys.argv[1]), sys.argv[2]
info = json.loads((root / "meta" / "info.json").read_text())
ds = LeRobotDataset(repo_id, root=root, video_backend="pyav")
assert ds.num_episodes == info["total_episodes"], (ds.num_episodes, info["total_episodes"])
assert ds.num_frames == info["total_frames"] == len(ds), (ds.num_frames, len(ds))
for idx in (0, len(ds) // 2, len(ds) - 1):
    item = ds[idx]
    assert int(item["index"]) == idx
    assert item["observation.state"].shape == (7,) and item["action"].shape == (7,)
    for key in ds.meta.video_keys:
        h, w, _ = info["features"][key]["shape"]
        assert tuple(item[key].shape) == (3, h, w), (key, item[key].shape)
    # Depth (uint16 mm) and segmentation (uint16 ids) are 16-bit PNG image features in the parquet.
    for key, feat in info["features"].items():
        if feat.get("dtype") == "image":
            h, w, _ = feat["shape"]
            assert tuple(item[key].shape) == (1, h, w), (key, item[key].shape)
    assert isinstance(item["task"], str) and item["task"]
print(f"check_lerobot: OK: lerobot loaded {root} ({ds.num_episodes} episodes, {ds.num_frames} frames, "
      f"{ds.fps} fps, videos {ds.meta.video_keys}, images {ds.meta.image_keys}); first task: {ds[0]['task']!r}")
PY
