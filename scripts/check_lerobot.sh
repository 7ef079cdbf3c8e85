#!/usr/bin/env bash
# Prove that LeRobot itself uses a samplehd LeRobot export, unchanged: make a Python 3.12 venv
# (lerobot >= 0.5 needs 3.12) with lerobot 0.6.1, open the export with LeRobotDataset(repo_id,
# root=...), then train LeRobot's own ACT and Diffusion policies on it for a few steps with its own
# `lerobot-train` (on the CPU, no checkpoints, nothing pushed). Not part of `make test`.
#
# usage: scripts/check_lerobot.sh EXPORT_DIR [REPO_ID] [STEPS]
#   env: LEROBOT_VENV (default .venv-lerobot; reused when it exists), PYTHON312 (default: pyenv's
#        3.12.1, else python3.12), POLICIES (default "act diffusion").
#
# Download: lerobot 0.6.1 needs torch < 2.12 and this machine holds a CPU torch wheel only for
# Python 3.11, so the first run downloads PyPI's torch for 3.12 (a CUDA build, with its nvidia-*
# libraries: about 5 GB in the venv). Build the venv once and point LEROBOT_VENV at it afterwards.
# Backbones start from random weights (--policy.pretrained_backbone_weights=null): the default
# ImageNet weights are a download from the hub at run time.
set -euo pipefail
export_dir="${1:?usage: scripts/check_lerobot.sh EXPORT_DIR [REPO_ID] [STEPS]}"
repo_id="${2:-samplehd/dataset}"
steps="${3:-5}"
policies="${POLICIES:-act diffusion}"
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
if ! "$venv/bin/python" -c "import lerobot, datasets, accelerate, diffusers" 2>/dev/null; then
  "$venv/bin/python" -m pip install --quiet "lerobot[dataset,training,diffusers-dep]==0.6.1"
fi
export HF_HUB_OFFLINE=1 HF_DATASETS_OFFLINE=1 WANDB_MODE=disabled

"$venv/bin/python" - "$export_dir" "$repo_id" <<'PY'
import json, sys
from pathlib import Path

from lerobot.datasets.lerobot_dataset import LeRobotDataset
from lerobot.utils.feature_utils import dataset_to_policy_features

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
    # Opt-in depth (uint16 mm) and segmentation (uint16 ids): (H, W) arrays, not cameras.
    for key, feat in info["features"].items():
        if key.startswith(("depth.", "segmentation.")):
            assert tuple(item[key].shape) == tuple(feat["shape"]), (key, item[key].shape)
    assert isinstance(item["task"], str) and item["task"]
feats = dataset_to_policy_features(ds.meta.features)
kinds = {k: f.type.name for k, f in feats.items()}
print(f"check_lerobot: OK: lerobot loaded {root} ({ds.num_episodes} episodes, {ds.num_frames} frames, "
      f"{ds.fps} fps, videos {ds.meta.video_keys}); policy features {kinds}")
PY

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
for policy in $policies; do
  "$venv/bin/lerobot-train" \
    --dataset.repo_id="$repo_id" --dataset.root="$export_dir" --dataset.video_backend=pyav \
    --policy.type="$policy" --policy.device=cpu --policy.push_to_hub=false \
    --policy.pretrained_backbone_weights=null \
    --steps="$steps" --batch_size=4 --num_workers=0 --log_freq=1 --save_checkpoint=false \
    --wandb.enable=false --output_dir="$work/$policy" > "$work/$policy.log" 2>&1 \
    || { tail -n 40 "$work/$policy.log" >&2; echo "check_lerobot: $policy training FAILED" >&2; exit 1; }
  done_steps=$(grep -c "step:" "$work/$policy.log" || true)
  first=$(grep "step:" "$work/$policy.log" | head -n 1 | grep -o ' loss:[0-9.e+-]*' | head -n 1)
  last=$(grep "step:" "$work/$policy.log" | tail -n 1 | grep -o ' loss:[0-9.e+-]*' | head -n 1)
  echo "check_lerobot: OK: lerobot-train --policy.type=$policy ran $steps steps on $export_dir ($done_steps logged; first step$first, last step$last)"
done
