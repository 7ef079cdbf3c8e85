#!/usr/bin/env bash
# One keypose policy for all seven task families (docs/BASELINES.md#one-policy-for-all-seven-families):
# a states-only dataset of demonstrations of every family on SAMPLE-HD's SHOP-VRB shapes with 640x360
# scene images (scripts/baselines/keypose_all.json) and two of stack_three alone
# (scripts/baselines/keypose_stack_three.json: a three-object stack needs a plate in the middle, which
# few scenes of all shapes hold: 49 of the first's 5,007 episodes; keypose_stack_three_tops.json: the
# bowl and the thermos on top, classes the first leaves out), each proven by replay; one keypose
# policy trained on all three, its grasp map reading the instruction per cell (--grasp-head product)
# and its code the count of objects it has put down so far (--placed-count);
# evaluated closed loop on the shipped benchmark suite `core`: its SHOP-VRB cells (every family x L1-L4,
# the first PER_CELL episodes of each), with the rule of grounding by exclusion at L4, and one video per
# family at L1.
#
# usage: scripts/baselines/keypose_all.sh [OUT]          (default OUT: outputs/keypose_all)
#   env: WORKERS (generate/evaluate processes, default: all cores), DEVICE (default: automatic),
#        STEPS (optimiser steps, default 6000), PER_CELL (core episodes per family x level, default 10;
#        at most 25), NS_MODELS (a folder with parser/ and perception/: the neuro-symbolic loop on the
#        same episodes), BLIND (set: also the language-blind control, trained and evaluated the same way
#        with the instruction blanked in training and when it acts), STACK_THREE (0: without the
#        stack_three datasets; docs/experiments/2026-12-keypose-all.md measures both)
#
# Every step resumes: run it again after an interruption and finished parts are skipped or resumed.
# Writes OUT/data/all (and OUT/data/stack_three, OUT/data/stack_three_tops), OUT/models/keypose_all,
# OUT/reports/*.json, OUT/reports/*.md, OUT/videos/ and OUT/summary.txt.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
# shellcheck source=scripts/baselines/demonstrations.sh
source "$here/demonstrations.sh"
out="${1:-outputs/keypose_all}"
workers="${WORKERS:-$(nproc)}"
device=()
[[ -n "${DEVICE:-}" ]] && device=(--device "$DEVICE")
bin="${SAMPLEHD:-samplehd}"
mkdir -p "$out/data" "$out/models" "$out/reports"
start=$(date +%s)

data="$out/data/all"
demonstrations "$here/keypose_all.json" "$data" "$out/reports/replay_all.txt"
datasets=("$data")
if [[ "${STACK_THREE:-1}" != 0 ]]; then
  datasets+=("$out/data/stack_three" "$out/data/stack_three_tops")
  demonstrations "$here/keypose_stack_three.json" "$out/data/stack_three" "$out/reports/replay_stack_three.txt"
  demonstrations "$here/keypose_stack_three_tops.json" "$out/data/stack_three_tops" \
    "$out/reports/replay_stack_three_tops.txt"
fi
model="$out/models/keypose_all"
[[ -f "$model/model.pt" ]] || "$bin" train policy --action keypose --grasp-head product --placed-count \
  --dataset "${datasets[@]}" --out "$model" --steps "${STEPS:-6000}" --quiet "${device[@]}"
trained=$(date +%s)

# the suite's SHOP-VRB cells, PER_CELL episodes each: a named, hashed part of core
per="${PER_CELL:-10}"
suite="$out/reports/core_shop_$per.json"
[[ -f "$suite" ]] || "$bin" suite build "core-shop-$per" --base core --catalogues shop-vrb --base-per-cell "$per" \
  --out "$suite" --quiet
report="$out/reports/keypose_all_core.json"
[[ -f "$report" ]] || "$bin" evaluate --policy bc --models "$model" --suite "$suite" --workers "$workers" --out "$report"
if [[ -n "${NS_MODELS:-}" && ! -f "$out/reports/neurosymbolic_core.json" ]]; then
  "$bin" evaluate --policy neurosymbolic --models "$NS_MODELS" --suite "$suite" --workers "$workers" \
    --out "$out/reports/neurosymbolic_core.json"
fi
if [[ -n "${BLIND:-}" ]]; then
  blind="$out/models/keypose_all_blind"
  [[ -f "$blind/model.pt" ]] || "$bin" train policy --action keypose --grasp-head product --placed-count --blind-language \
    --dataset "${datasets[@]}" --out "$blind" --steps "${STEPS:-6000}" --quiet "${device[@]}"
  [[ -f "$out/reports/keypose_blind_core.json" ]] || "$bin" evaluate --policy bc --models "$blind" --suite "$suite" \
    --workers "$workers" --out "$out/reports/keypose_blind_core.json"
fi
# one video per family: the first L1 episode of each, filmed at 480x360 (the env's images, which the
# keypose policy does not read: it renders its own view of the table)
videos="$out/reports/core_shop_l1_video.json"
[[ -f "$videos" ]] || "$bin" suite build core-shop-l1-video --base core --catalogues shop-vrb --levels L1 \
  --base-per-cell 1 --out "$videos" --quiet
[[ -f "$out/reports/video_env.json" ]] || echo '{"width": 480, "height": 360}' > "$out/reports/video_env.json"
[[ -f "$out/reports/keypose_all_videos.json" ]] || "$bin" evaluate --policy bc --models "$model" --suite "$videos" \
  --workers "$workers" --env-options "$out/reports/video_env.json" --video "$out/videos" \
  --out "$out/reports/keypose_all_videos.json"

{
  commit=$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)
  echo "samplehd keypose_all recipe: $(date -u +%FT%TZ), commit $commit, $(($(date +%s) - start)) s" \
    "(data + training $((trained - start)) s), $(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs))," \
    "load $(cut -d' ' -f1-3 /proc/loadavg)"
  "${PYTHON:-$(dirname "$(command -v "$bin")")/python}" "$here/keypose_table.py" "$out/reports/keypose_all_core.json" \
    "$out/reports/keypose_blind_core.json" "$out/reports/neurosymbolic_core.json"
} | tee "$out/summary.txt"
