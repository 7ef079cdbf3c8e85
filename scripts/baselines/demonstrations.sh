# shellcheck shell=bash
# Sourced by bc.sh and keypose.sh: demonstrations CONFIG DATA REPORT makes the dataset DATA from the
# generate config CONFIG (finishing an interrupted run with --resume, skipping a complete one), then
# proves it by replay (every recorded episode must replay to its recorded outcome), the report in REPORT.
# Uses $bin (the samplehd command) and $workers.
demonstrations() {
  local config="$1" data="$2" report="$3" resume=()
  if ! { [[ -f "$data/info.json" ]] && grep -q '"status": "complete"' "$data/info.json"; }; then
    [[ -d "$data" ]] && resume=(--resume)
    "$bin" generate --preset small --config "$config" --workers "$workers" --out "$data" --quiet "${resume[@]}"
  fi
  "$bin" validate "$data" --replay --episodes 50 | tee "$report"
}
