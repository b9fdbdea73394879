#!/usr/bin/env bash
# handscs-view's figures (docs/BENCHMARKS.md, "Live viewer"): for avatars of 2,872 Gaussians (the
# demo's count) and 10,000, the loopback load test (handscs-bench-view: FPS and latency with 1 and
# 4 clients) and the end-to-end latency in headless Chromium (tests/view/browser_check.mjs).
# The avatars grow to their counts the way handscs-bench-model's do: densification at every step
# from step 1, any Gaussian with a gradient split or cloned, capped at the count (their pictures
# are not trained ones; only the count matters for speed).
#   tools/study/bench_view.sh [OUT_DIR]     (default /tmp/handscs-bench-view); builds what it needs
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
out="${1:-/tmp/handscs-bench-view}"
bin="$root/build/bin"
"$root/scripts/build.sh" handscs-view handscs-bench-view handscs-train handscs-synth handscs-render >/dev/null
mkdir -p "$out"
[ -d "$out/capture" ] || "$bin/handscs-synth" --preset tiny --out "$out/capture" --threads 1 >/dev/null
for n in 2872 10000; do
  run="$out/run_$n"
  if ! ls "$run"/checkpoints/*.ckpt >/dev/null 2>&1; then
    "$bin/handscs-train" --config "$root/configs/tiny.json" --out "$run" --overwrite --threads 1 \
      --set data.root="$out/capture" --set train.iterations=14 --set train.checkpoint_every=14 \
      --set train.validate_every=0 --set train.densify.enabled=true --set train.densify.start=1 \
      --set train.densify.interval=1 --set train.densify.stop=12 --set train.densify.grad_threshold=1e-12 \
      --set train.densify.min_opacity=0 --set train.densify.max_gaussians=$n >/dev/null
  fi
  echo "== $n Gaussians: uptime $(uptime)" >&2
  "$bin/handscs-bench-view" --checkpoint "$run" --threads 1 --seconds 10 --max-frames 300 > "$out/load_$n.json"
  "$root/tests/view/browser_test.sh" "$bin" "$out/browser" --run "$run" --bench 30 --label "$n" > "$out/browser_$n.json"
  cat "$out/load_$n.json" "$out/browser_$n.json"
done
