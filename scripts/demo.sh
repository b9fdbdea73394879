#!/usr/bin/env bash
# The demo on a fresh machine: installs what is missing, builds, synthesises the realistic `real_demo` capture of the
# built-in hand (InterHand2.6M layout), trains an avatar with configs/demo.json, evaluates it on the 50
# held-out poses (PSNR/SSIM/LPIPS), renders a novel-pose orbit video, and says where everything is.
# Output folder: $HANDSCS_DEMO_OUT (default out/demo). A second run reuses the capture.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${HANDSCS_DEMO_OUT:-$root/out/demo}"
start=$(date +%s)
"$root/scripts/install-deps.sh"
# Only the four programs the demo runs: the tests and benchmarks would double a cold build.
"$root/scripts/build.sh" handscs-synth handscs-train handscs-eval handscs-render
bin="$root/build/bin"
mkdir -p "$out"

if [ ! -f "$out/capture/annotations/test/InterHand2.6M_test_data.json" ]; then
  "$bin/handscs-synth" --preset real_demo --out "$out/capture"
fi

# LPIPS weights are used (loss and metric) when the shared copy is beside the project.
lpips="$root/../shared/assets/lpips/lpips_alex_v0.1.pt"
lpips_set=()
[ -f "$lpips" ] && lpips_set=("eval.lpips.weights=$lpips")

rm -rf "$out/run"
"$bin/handscs-train" --config "$root/configs/demo.json" --out "$out/run" \
  --set "data.root=$out/capture" "${lpips_set[@]}"

"$bin/handscs-eval" --checkpoint "$out/run" --out "$out/eval" > "$out/eval.log"

cat > "$out/novel_poses.json" <<JSON
{"capture": {"root": "$out/capture", "held_out_poses": 50}, "frames": "test", "camera": "400002", "max_frames": 50}
JSON
"$bin/handscs-render" --checkpoint "$out/run" --poses "$out/novel_poses.json" --orbit 50 \
  --out "$out/orbit" --video "$out/orbit.mp4"

echo
echo "Demo finished in $(( $(date +%s) - start )) s. Novel-pose quality (50 held-out poses x the 10 colour cameras):"
cat "$out/eval/table.md"
grep "^rendering:" "$out/eval.log" || true
echo
echo "Outputs:"
echo "  synthetic capture (InterHand2.6M layout): $out/capture"
echo "  run folder (config, metrics.csv, checkpoints, validation renders): $out/run"
echo "  evaluation (summary.json, per_image.csv, table.md): $out/eval"
echo "  novel-pose orbit: $out/orbit.mp4 (frames in $out/orbit)"
