#!/usr/bin/env bash
# handscs-view in headless Chromium (ctest "view: browser"): makes a tiny trained run, installs
# puppeteer-core into the build folder (once; never into the source tree), and runs
# browser_check.mjs. Skips (exit 77) only when Chromium is missing: scripts/install-deps.sh installs it.
#   browser_test.sh BIN_DIR WORK_DIR [--hands both] [browser_check.mjs options...]  (a --run RUN there
#   replaces the tiny run; --hands both trains it on the two-hand both_tiny capture instead)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
bin="$1"
work="$2"
shift 2
preset=tiny
hand_keys=()
if [ "${1:-}" = "--hands" ]; then
  [ "${2:-}" = "both" ] || { echo "browser test: --hands takes \"both\""; exit 1; }
  preset=both_tiny
  hand_keys=(--set data.hand=both)
  shift 2
fi
chromium="${CHROMIUM:-/usr/bin/chromium}"
if [ ! -x "$chromium" ]; then
  echo "SKIP: $chromium is not installed (scripts/install-deps.sh installs Debian's chromium)"
  exit 77
fi
command -v node >/dev/null || { echo "browser test: node is missing (the machine's Node.js)"; exit 1; }

# puppeteer-core without its own browser download (Debian's chromium is used), pinned.
# Shared by the browser tests of one build folder (they hold one lock, tests/CMakeLists.txt).
modules="$(dirname "$work")/view_browser_node"
if [ ! -f "$modules/node_modules/puppeteer-core/package.json" ]; then
  mkdir -p "$modules"
  PUPPETEER_SKIP_DOWNLOAD=1 npm install --prefix "$modules" --no-audit --no-fund --loglevel=error \
    puppeteer-core@24.43.1 >/dev/null
fi

# A tiny capture and a 5-step run on it (the picture must follow pose and camera, not be good).
run="$work/run"
if [ ! -f "$run/config.json" ] || ! ls "$run"/checkpoints/*.ckpt >/dev/null 2>&1; then
  rm -rf "$work/capture" "$run"
  "$bin/handscs-synth" --preset "$preset" --out "$work/capture" --threads 1 >/dev/null
  "$bin/handscs-train" --config "$here/../../configs/tiny.json" --out "$run" --threads 1 \
    --set data.root="$work/capture" "${hand_keys[@]}" --set train.iterations=5 --set train.checkpoint_every=5 \
    --set train.validate_every=0 >/dev/null
fi

CHROMIUM="$chromium" node "$here/browser_check.mjs" --modules "$modules" --bin "$bin" --run "$run" \
  --work "$work/check" "$@"
