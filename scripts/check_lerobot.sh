#!/usr/bin/env bash
# Prove that LeRobot itself uses samplehd, unchanged, end to end: make a Python 3.12 venv (lerobot
# >= 0.5 needs 3.12) with lerobot 0.6.1, samplehd and the env plugin lerobot_env_samplehd; make a
# small pick_up export when none is given; open it with LeRobotDataset(repo_id, root=...); train
# LeRobot's own policies on its train split with `lerobot-train`; then run the ACT checkpoint in
# samplehd's environment with `lerobot-eval --env.type=samplehd` and with `samplehd evaluate --policy
# lerobot:CKPT`, and check that both report the same success on every episode. Not part of `make test`.
#
# usage: scripts/check_lerobot.sh [EXPORT_DIR] [REPO_ID] [STEPS]
#   EXPORT_DIR: a `samplehd export lerobot` folder (default: make one in WORK from DEMOS pick_up scenes)
#   env: LEROBOT_VENV (default ~/.cache/samplehd/lerobot-venv; reused when it exists), PYTHON312
#        (default: pyenv's 3.12.1, else python3.12), POLICIES (default "act diffusion"), WORK (default:
#        a temporary folder, removed at the end), DEMOS (scenes of the made export, default 8), SIZE
#        (its square image side, default 96), EVAL_EPISODES (default 3; 0 skips lerobot-eval),
#        EVAL_STEPS (steps per evaluated episode, default 150), TASK (default pick_up), LEVEL (train on
#        meta/splits/train_LEVEL.json and evaluate at that level; default L1, empty: train.json and the
#        plain split).
#
# Download: lerobot 0.6.1 needs torch < 2.12; where no CPU wheel for 3.12 is at hand the first run
# downloads PyPI's torch (a CUDA build with its nvidia-* libraries: about 5 GB in the venv). Build the
# venv once and point LEROBOT_VENV at it afterwards. Backbones start from random weights
# (--policy.pretrained_backbone_weights=null): the default ImageNet weights are a hub download.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export_dir="${1:-}"
repo_id="${2:-samplehd/dataset}"
steps="${3:-5}"
policies="${POLICIES:-act diffusion}"
venv="${LEROBOT_VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/samplehd/lerobot-venv}"
eval_episodes="${EVAL_EPISODES:-3}"
eval_steps="${EVAL_STEPS:-150}"
task="${TASK:-pick_up}"
level="${LEVEL-L1}"
py="${PYTHON312:-}"
if [[ -z "$py" ]]; then
  for cand in /root/.pyenv/versions/3.12.1/bin/python3 "$(command -v python3.12 || true)"; do
    if [[ -n "$cand" && -x "$cand" ]]; then py="$cand"; break; fi
  done
fi
[[ -n "$py" ]] || { echo "check_lerobot: no Python 3.12 found (set PYTHON312)" >&2; exit 2; }
if [[ ! -x "$venv/bin/python" ]]; then
  mkdir -p "$(dirname "$venv")"
  "$py" -m venv "$venv"
  "$venv/bin/python" -m pip install --quiet --upgrade pip
fi
if ! "$venv/bin/python" -c "import lerobot, datasets, accelerate, diffusers" 2>/dev/null; then
  "$venv/bin/python" -m pip install --quiet "lerobot[dataset,training,diffusers-dep]==0.6.1"
fi
if ! "$venv/bin/python" -c "import samplehd, pyarrow, lerobot_env_samplehd" 2>/dev/null; then
  "$venv/bin/python" -m pip install --quiet -e "$repo[lerobot]" -e "$repo/plugins/lerobot_env_samplehd"
fi
export HF_HUB_OFFLINE=1 HF_DATASETS_OFFLINE=1 WANDB_MODE=disabled

work="${WORK:-}"
if [[ -z "$work" ]]; then
  work="$(mktemp -d)"
  trap 'rm -rf "$work"' EXIT
fi
mkdir -p "$work"
if [[ -z "$export_dir" ]]; then
  export_dir="$work/export"
  if [[ ! -d "$export_dir" ]]; then
    printf '{"instructions": {"per_scene": 1, "families": ["%s"]}, "test_every": 4}\n' "$task" > "$work/demos.json"
    t0=$SECONDS
    "$venv/bin/samplehd" generate --preset tiny --config "$work/demos.json" --out "$work/dataset" \
      --scenes "${DEMOS:-8}" --render fast --width "${SIZE:-96}" --height "${SIZE:-96}" --cameras scene \
      --modalities rgb --quiet > "$work/generate.log"
    "$venv/bin/samplehd" export lerobot "$work/dataset" --out "$export_dir" --repo-id "$repo_id" \
      > "$work/export.log" 2>&1 || { cat "$work/export.log" >&2; exit 1; }
    echo "check_lerobot: OK: made $export_dir from ${DEMOS:-8} $task scenes in $((SECONDS - t0)) s"
  fi
fi

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
        h, w, c = info["features"][key]["shape"]  # c = 1: a native depth video (export --depth-video)
        assert tuple(item[key].shape) == (c, h, w), (key, item[key].shape)
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

# The train split only (samplehd's test episodes stay out; with LEVEL, what that level holds out too),
# where the export lists it.
episodes=()
split_file="$export_dir/meta/splits/train${level:+_$level}.json"
[[ -f "$split_file" ]] || split_file="$export_dir/meta/splits/train.json"
if [[ -f "$split_file" ]]; then
  episodes=(--dataset.episodes="$(cat "$split_file")")
fi
level_flag=()
[[ -n "$level" ]] && level_flag=(--env.level="$level")
for policy in $policies; do
  save=(--save_checkpoint=false)
  if [[ "$policy" == act && "$eval_episodes" -gt 0 ]]; then save=(--save_checkpoint=true --save_freq="$steps"); fi
  t0=$SECONDS
  "$venv/bin/lerobot-train" \
    --dataset.repo_id="$repo_id" --dataset.root="$export_dir" --dataset.video_backend=pyav "${episodes[@]}" \
    --policy.type="$policy" --policy.device=cpu --policy.push_to_hub=false \
    --policy.pretrained_backbone_weights=null \
    --steps="$steps" --batch_size=4 --num_workers=0 --log_freq=1 "${save[@]}" \
    --wandb.enable=false --output_dir="$work/$policy" > "$work/$policy.log" 2>&1 \
    || { tail -n 40 "$work/$policy.log" >&2; echo "check_lerobot: $policy training FAILED" >&2; exit 1; }
  done_steps=$(grep -c "step:" "$work/$policy.log" || true)
  first=$(grep "step:" "$work/$policy.log" | head -n 1 | grep -o ' loss:[0-9.e+-]*' | head -n 1)
  last=$(grep "step:" "$work/$policy.log" | tail -n 1 | grep -o ' loss:[0-9.e+-]*' | head -n 1)
  echo "check_lerobot: OK: lerobot-train --policy.type=$policy ran $steps steps on $export_dir" \
       "($done_steps logged; first step$first, last step$last; $((SECONDS - t0)) s)"
done

if [[ "$eval_episodes" -gt 0 && " $policies " == *" act "* ]]; then
  t0=$SECONDS
  "$venv/bin/lerobot-eval" --policy.path="$work/act/checkpoints/last/pretrained_model" --policy.device=cpu \
    --env.type=samplehd --env.task="$task" --env.dataset="$export_dir" --env.episode_length="$eval_steps" \
    "${level_flag[@]}" \
    --eval.n_episodes="$eval_episodes" --eval.batch_size=1 --seed=0 --output_dir="$work/eval" \
    > "$work/eval.log" 2>&1 \
    || { tail -n 40 "$work/eval.log" >&2; echo "check_lerobot: lerobot-eval FAILED" >&2; exit 1; }
  "$venv/bin/python" - "$work/eval/eval_info.json" "$task" "$eval_episodes" "$eval_steps" "$((SECONDS - t0))" <<'PY'
import json, sys

info, task, n, steps, wall = json.load(open(sys.argv[1])), *sys.argv[2:]
overall = info["overall"]
assert overall["n_episodes"] == int(n), overall
print(f"check_lerobot: OK: lerobot-eval --env.type=samplehd --env.task={task} ran ACT on {n} episodes of "
      f"samplehd evaluate's split (seed 0, ≤ {steps} steps each): pc_success {overall['pc_success']:.1f} %, "
      f"avg_sum_reward {overall['avg_sum_reward']:.2f}, {wall} s")
PY
  # The same checkpoint on the same episodes through samplehd's CLI: same success, episode by episode.
  t0=$SECONDS
  "$venv/bin/samplehd" evaluate --policy "lerobot:$work/act/checkpoints/last/pretrained_model" \
    --families "$task" --episodes "$eval_episodes" --max-episode-steps "$eval_steps" --seed 0 \
    ${level:+--level "$level"} --out "$work/samplehd_eval.json" > "$work/samplehd_eval.log" 2>&1 \
    || { tail -n 20 "$work/samplehd_eval.log" >&2; echo "check_lerobot: samplehd evaluate FAILED" >&2; exit 1; }
  "$venv/bin/python" - "$work/eval/eval_info.json" "$work/samplehd_eval.json" "$((SECONDS - t0))" <<'PY'
import json, sys

theirs = [bool(s) for t in json.load(open(sys.argv[1]))["per_task"] for s in t["metrics"]["successes"]]
report = json.load(open(sys.argv[2]))
ours = [r["success"] for r in report["records"]]
assert ours == theirs, f"lerobot-eval successes {theirs} != samplehd evaluate successes {ours}"
print(f"check_lerobot: OK: samplehd evaluate --policy lerobot:CKPT agrees with lerobot-eval on all {len(ours)} "
      f"episodes: {sum(ours)}/{len(ours)} succeed (mean steps {report['mean_steps']:.0f}, {sys.argv[3]} s)")
PY
fi
