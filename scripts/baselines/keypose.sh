#!/usr/bin/env bash
# The keypose behaviour-cloning recipe of docs/BASELINES.md in one command: per family (pick_up, place),
# a states-only dataset of demonstrations with 640x360 scene images, proven by replay; the keypose policy
# (top-down view of the scene camera's RGB-D + instruction -> where to grasp, where the object goes)
# trained on it; evaluated closed loop on L1 episodes of the seeded benchmark split (held out: drawn
# from seeds no dataset uses).
#
# usage: scripts/baselines/keypose.sh [OUT]          (default OUT: outputs/keypose)
#   env: WORKERS (generate/evaluate processes, default: all cores), DEVICE (default: automatic),
#        STEPS (optimiser steps; pick_up 4000, place 3000), EPISODES (closed-loop episodes per family, 50),
#        FAMILIES (default "pick_up place"), BLIND=1 (the language-blind control: models/keypose_blind_FAMILY,
#        trained and evaluated on a blank instruction)
#
# Scenes draw SAMPLE-HD's SHOP-VRB shapes (samplehd's default catalogue). Figures of docs/BASELINES.md
# measured before that default used the procedural shapes: add "catalogue": "procedural" to the "scene"
# of the configs to repeat them.
#
# Every step resumes: run it again after an interruption and finished parts are skipped or resumed.
# Writes OUT/data/FAMILY, OUT/models/keypose_FAMILY, OUT/reports/*.json and OUT/summary.txt.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
# shellcheck source=scripts/baselines/demonstrations.sh
source "$here/demonstrations.sh"
out="${1:-outputs/keypose}"
workers="${WORKERS:-$(nproc)}"
device=()
[[ -n "${DEVICE:-}" ]] && device=(--device "$DEVICE")
episodes="${EPISODES:-50}"
bin="${SAMPLEHD:-samplehd}"
mkdir -p "$out/data" "$out/models" "$out/reports"
blind=() suffix=""
if [[ "${BLIND:-0}" == 1 ]]; then blind=(--blind-language); suffix="_blind"; fi
declare -A limit=([pick_up]=300 [place]=1500) steps=([pick_up]=4000 [place]=3000)
start=$(date +%s)

for family in ${FAMILIES:-pick_up place}; do
  data="$out/data/$family"
  demonstrations "$here/keypose_$family.json" "$data" "$out/reports/replay_$family.txt"
  model="$out/models/keypose${suffix}_$family"
  [[ -f "$model/model.pt" ]] || "$bin" train policy --action keypose --dataset "$data" --out "$model" \
    --steps "${STEPS:-${steps[$family]}}" --quiet "${device[@]}" "${blind[@]}"
  "$bin" evaluate --policy bc --models "$model" --families "$family" --level L1 --episodes "$episodes" \
    --max-episode-steps "${limit[$family]}" --workers "$workers" --out "$out/reports/keypose${suffix}_$family.json"
done

{
  commit=$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)
  echo "samplehd keypose recipe: $(date -u +%FT%TZ), commit $commit, $(($(date +%s) - start)) s," \
    "$(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)), load $(cut -d' ' -f1-3 /proc/loadavg)"
  for report in "$out"/reports/keypose${suffix}_*.json; do
    python3 -c 'import json, sys; r = json.load(open(sys.argv[1])); o = r["statistics"]["overall"]
print(sys.argv[1], r["successes"], "/", r["episodes"], "(95 %% Wilson %.1f-%.1f %%)" % (100 * o["low"], 100 * o["high"]))' "$report"
  done
} | tee "$out/summary.txt"
