#!/usr/bin/env bash
# The Baselines table of docs/BASELINES.md end to end: generate the two datasets, train the parser, perception and
# behaviour-cloning models, and evaluate the neuro-symbolic and BC policies on the seeded benchmark
# split. Training uses CUDA when torch sees a GPU, else the CPU (pass DEVICE=cpu|cuda to choose).
#
# usage: scripts/baselines/run.sh [OUT]          (default OUT: outputs/baselines)
#   env: WORKERS (generate/evaluate processes, default: all cores), DEVICE (default: automatic),
#        PERCEPTION_STEPS (4000), PARSER_STEPS (1000), POLICY_STEPS (4000), BC_EPISODES (300),
#        EPISODES (closed-loop episodes per evaluation, 48)
#
# Scenes draw SAMPLE-HD's SHOP-VRB shapes (samplehd's default catalogue). Figures of docs/BASELINES.md
# measured before that default used the procedural shapes: add "catalogue": "procedural" to the "scene"
# of the configs to repeat them.
#
# Every step resumes: run it again after an interruption and finished parts are skipped or resumed.
# Writes OUT/data/{small1200,bc}, OUT/models/{parser,perception,policy}, OUT/reports/*.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
out="${1:-outputs/baselines}"
workers="${WORKERS:-$(nproc)}"
device=()
[[ -n "${DEVICE:-}" ]] && device=(--device "$DEVICE")
episodes="${EPISODES:-48}"
bin="${SAMPLEHD:-samplehd}"
mkdir -p "$out/data" "$out/models" "$out/reports"

gen() {  # gen NAME ARGS...: generate (or finish) a dataset
  local name="$1"; shift
  if [[ -f "$out/data/$name/info.json" ]] && grep -q '"status": "complete"' "$out/data/$name/info.json"; then
    return
  fi
  local resume=()
  [[ -d "$out/data/$name" ]] && resume=(--resume)
  "$bin" generate --preset small "$@" --workers "$workers" --out "$out/data/$name" "${resume[@]}"
}

# 1200 scenes with 640x360 scene images (RGB, depth, segmentation); every 10th scene is a test scene.
gen small1200 --config "$here/scenes.json" --scenes 1200 --target 1200 --render none --width 640 --height 360 --seed 0
# pick_up and place demonstrations with 64x64 scene and wrist camera RGB.
gen bc --config "$here/bc.json" --target "${BC_EPISODES:-300}"

"$bin" train parser --dataset "$out/data/small1200" --out "$out/models/parser" --steps "${PARSER_STEPS:-1000}" \
  "${device[@]}"
"$bin" train perception --dataset "$out/data/small1200" --out "$out/models/perception" \
  --steps "${PERCEPTION_STEPS:-4000}" "${device[@]}"
"$bin" train policy --dataset "$out/data/bc" --out "$out/models/policy" --steps "${POLICY_STEPS:-4000}" \
  "${device[@]}"

ns() {  # ns NAME ARGS...: one neuro-symbolic evaluation
  local name="$1"; shift
  "$bin" evaluate --policy neurosymbolic --models "$out/models" --episodes "$episodes" --workers "$workers" \
    --out "$out/reports/$name.json" "$@"
}
ns gt_gt --programs gt --perception gt --level L1
ns predicted_gt --programs predicted --perception gt --level L1
ns predicted_predicted --programs predicted --perception predicted --level L1
for level in L2 L4; do
  ns "predicted_predicted_$level" --level "$level" --episodes 8 --families pick_up place place_relative put
done
for level in L1 L2 L4; do
  "$bin" evaluate --policy bc --models "$out/models/policy" --families pick_up place --level "$level" \
    --episodes "$episodes" --max-episode-steps 400 --workers "$workers" --out "$out/reports/bc_$level.json"
done
