#!/usr/bin/env bash
# MediaPipe Hands' 2D landmarks for a folder of per-view images, in the format `handscs-fit
# --multiview` reads (OUT/NN.json for each image NN.png or NN.jpg; docs/FIT.md). Runs the npm
# package @mediapipe/hands in headless Chromium, driven by puppeteer-core; both are installed once
# into WORK/node (never into the source tree). Needs Debian's chromium and Node.js
# (scripts/install-deps.sh) and, the first time, the npm registry.
#   detect_landmarks.sh IMAGES_DIR OUT_DIR [--work DIR] [--max-hands 1|2] [--model-complexity 0|1]
#                       [--min-confidence C]
# WORK defaults to $HANDSCS_DETECT_WORK, else ~/.cache/handscs/detect_landmarks.
# Prints one JSON line: per view, the detections' labels and scores.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
if [ $# -lt 2 ]; then
  sed -n '2,10p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
  exit 2
fi
images="$1"
out="$2"
shift 2
work="${HANDSCS_DETECT_WORK:-${XDG_CACHE_HOME:-$HOME/.cache}/handscs/detect_landmarks}"
options=()
while [ $# -gt 0 ]; do
  case "$1" in
    --work) work="$2"; shift 2 ;;
    --max-hands|--model-complexity|--min-confidence) options+=("$1" "$2"); shift 2 ;;
    *) echo "detect_landmarks.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
chromium="${CHROMIUM:-/usr/bin/chromium}"
[ -x "$chromium" ] || { echo "detect_landmarks.sh: $chromium is missing (scripts/install-deps.sh installs chromium)" >&2; exit 1; }
command -v node >/dev/null || { echo "detect_landmarks.sh: node is missing (the machine's Node.js)" >&2; exit 1; }
[ -d "$images" ] || { echo "detect_landmarks.sh: $images is not a folder" >&2; exit 1; }

# Pinned: the last release of MediaPipe's legacy Hands solution (models and WASM inside the package),
# and the puppeteer-core the viewer's browser test uses, without its own browser download.
mediapipe_version=0.4.1675469240
puppeteer_version=24.43.1
modules="$work/node"
if [ "$(node -p "try { require('$modules/node_modules/@mediapipe/hands/package.json').version } catch (e) { '' }")" != "$mediapipe_version" ] ||
   [ ! -f "$modules/node_modules/puppeteer-core/package.json" ]; then
  mkdir -p "$modules"
  PUPPETEER_SKIP_DOWNLOAD=1 npm install --prefix "$modules" --no-audit --no-fund --loglevel=error \
    "puppeteer-core@$puppeteer_version" "@mediapipe/hands@$mediapipe_version" >/dev/null
fi
CHROMIUM="$chromium" node "$here/detect_landmarks.mjs" --modules "$modules" --images "$images" --out "$out" \
  --work "$work" "${options[@]}"
