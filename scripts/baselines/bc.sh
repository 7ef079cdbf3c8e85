#!/usr/bin/env bash
# The behaviour-cloning recipe of docs/BASELINES.md in one command: per family (pick_up, place), a dataset
# of demonstrations with 64x64 scene and wrist RGB, proven by replay; the visuomotor policy and the
# privileged-state reference trained on it; both evaluated closed loop on L1 episodes of the seeded
# benchmark split (held out: drawn from seeds no dataset uses).
#
# usage: scripts/baselines/bc.sh [OUT]          (default OUT: outputs/bc)
#   env: WORKERS (generate/evaluate processes, default: all cores), DEVICE (default: automatic),
#        STEPS (visuomotor optimiser steps, 4000), STATE_STEPS (privileged reference, 4000),
#        EPISODES (closed-loop episodes per family, 50), DEMOS / NOISE (DART episodes collected in the
#        environment and their noise, default 0 / 0.05), FAMILIES (default "pick_up place"),
#        ACTION (steering or waypoint, default steering)
#
# Scenes draw SAMPLE-HD's SHOP-VRB shapes (samplehd's default catalogue). Figures of docs/BASELINES.md
# measured before that default used the procedural shapes: add "catalogue": "procedural" to the "scene"
# of the configs to repeat them.
#
# Every step resumes: run it again after an interruption and finished parts are skipped or resumed.
# Writes OUT/data/FAMILY, OUT/models/{rgb,state}_FAMILY, OUT/reports/*.json and OUT/summary.txt.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
# shellcheck source=scripts/baselines/demonstrations.sh
source "$here/demonstrations.sh"
out="${1:-outputs/bc}"
workers="${WORKERS:-$(nproc)}"
device=()
[[ -n "${DEVICE:-}" ]] && device=(--device "$DEVICE")
episodes="${EPISODES:-50}"
bin="${SAMPLEHD:-samplehd}"
demos=()
[[ "${DEMOS:-0}" != 0 ]] && demos=(--demos "$DEMOS" --noise "${NOISE:-0.05}" --workers "$workers")
demos+=(--action "${ACTION:-steering}")
mkdir -p "$out/data" "$out/models" "$out/reports"
declare -A limit=([pick_up]=300 [place]=600)
start=$(date +%s)

for family in ${FAMILIES:-pick_up place}; do
  data="$out/data/$family"
  demonstrations "$here/bc_$family.json" "$data" "$out/reports/replay_$family.txt"
  "$bin" train policy --dataset "$data" --out "$out/models/rgb_$family" --steps "${STEPS:-4000}" --quiet \
    "${device[@]}" "${demos[@]}"
  "$bin" train policy --inputs state --dataset "$data" --out "$out/models/state_$family" \
    --steps "${STATE_STEPS:-4000}" --quiet "${device[@]}" "${demos[@]}"
  for inputs in rgb state; do
    "$bin" evaluate --policy bc --models "$out/models/${inputs}_$family" --families "$family" --level L1 \
      --episodes "$episodes" --max-episode-steps "${limit[$family]}" --workers "$workers" \
      --out "$out/reports/${inputs}_$family.json"
  done
done

{
  echo "samplehd BC recipe: $(date -u +%FT%TZ), $(($(date +%s) - start)) s, $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
  for report in "$out"/reports/*_*.json; do
    python3 -c 'import json, sys; r = json.load(open(sys.argv[1])); o = r["statistics"]["overall"]
print(sys.argv[1], r["successes"], "/", r["episodes"], "(95 %% Wilson %.1f-%.1f %%)" % (100 * o["low"], 100 * o["high"]))' "$report"
  done
} | tee "$out/summary.txt"
