#!/usr/bin/env bash
# Does recovery data help? The keypose policy trained on the same pick_up episodes with and without
# disturbances (half of them disturbed: missed_grasp, slip, nudge), the same number of training steps,
# evaluated on the same held-out episodes (evaluate's seed 4242, which no dataset uses), then paired.
#   scripts/baselines/keypose_recovery.sh [OUT]     (STEPS=1000 EPISODES=50 WORKERS=nproc)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
out="${1:-outputs/keypose_recovery}"
workers="${WORKERS:-$(nproc)}"
bin="${SAMPLEHD:-samplehd}"
mkdir -p "$out"
for variant in plain recovery; do
  extra=()
  [[ $variant == recovery ]] && extra=(--disturb 0.5 --disturb-kinds missed_grasp slip nudge)
  data="$out/data_$variant"
  if ! { [[ -f "$data/info.json" ]] && grep -q '"status": "complete"' "$data/info.json"; }; then
    "$bin" generate --preset small --config "$here/keypose_recovery.json" --workers "$workers" --out "$data" \
      --quiet "${extra[@]}"
  fi
  "$bin" validate "$data" --replay --episodes 50 | tail -1
  [[ -f "$out/model_$variant/model.pt" ]] || "$bin" train policy --action keypose --dataset "$data" \
    --out "$out/model_$variant" --steps "${STEPS:-1000}" --quiet
done
for variant in plain recovery; do
  "$bin" evaluate --policy bc --models "$out/model_$variant" --families pick_up --level L1 \
    --episodes "${EPISODES:-50}" --seed 4242 --max-episode-steps 300 --workers "$workers" \
    --out "$out/eval_$variant.json"
done
"$bin" compare "$out/eval_plain.json" "$out/eval_recovery.json" | tee "$out/compare.txt"
