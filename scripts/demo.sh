#!/usr/bin/env bash
# The demo on a fresh machine: installs what is missing, builds, and runs the main job on the built-in
# default (the procedural hand and a synthetic capture), then says where the results are.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${HANDSCS_DEMO_OUT:-$root/out/demo}"
"$root/scripts/install-deps.sh"
"$root/scripts/build.sh"
bin="$root/build/bin"
mkdir -p "$out"

steps=()
if [ -x "$bin/handscs-rig" ]; then
  "$bin/handscs-rig" --builtin --out "$out/builtin_hand.json"
  steps+=("built-in hand rig: $out/builtin_hand.json")
fi
if [ -x "$bin/handscs-synth" ]; then
  "$bin/handscs-synth" --preset demo --out "$out/capture"
  steps+=("synthetic capture (InterHand2.6M layout): $out/capture")
fi
if [ -x "$bin/handscs-eval" ] && [ -d "$root/../shared/testdata/metric_pairs" ]; then
  weights=()
  lpips="$root/../shared/assets/lpips/lpips_alex_v0.1.pt"
  [ -f "$lpips" ] && weights=(--lpips-weights "$lpips")
  "$bin/handscs-eval" --pred "$root/../shared/testdata/metric_pairs/dist" \
    --gt "$root/../shared/testdata/metric_pairs/ref" "${weights[@]}" --json "$out/metric_pairs.json"
  steps+=("metrics on the shared TID2013 pairs: $out/metric_pairs.json")
fi

echo
echo "Demo finished. Outputs:"
for s in "${steps[@]}"; do echo "  - $s"; done
