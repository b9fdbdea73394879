#!/usr/bin/env bash
# The measurement of docs/FIT.md, "A real detector's landmarks on synthetic images": MediaPipe
# Hands on the real_demo capture's views of ten fixed frames, handscs-fit --multiview on its
# landmarks, both against the capture's true joints; prints the Markdown tables.
#   detector_fit.sh BIN_DIR WORK_DIR NAME [--set key=value ...]
# The capture and the landmarks are made once under WORK_DIR and shared by every NAME; NAME's fits
# and reports go to WORK_DIR/NAME/ (the --set options are handscs-fit's).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
scripts="$here/../../scripts"
bin="$1"
work="$2"
name="$3"
shift 3
frames=(0 60 120 180 240 300 360 420 480 540)

capture="$work/capture"
if [ ! -f "$capture/capture.json" ]; then
  "$bin/handscs-synth" --preset real_demo --layout handscs --out "$capture" --threads 2 --log-level warn
fi
reports=()
for frame in "${frames[@]}"; do
  views="$work/views/$frame"
  if [ ! -f "$views/detector.json" ]; then
    rm -rf "$views"
    python3 "$scripts/capture_to_multiview.py" "$capture" "$frame" "$views"
    "$scripts/detect_landmarks.sh" "$views/img" "$views/pose" --work "$work/detector" > "$views/detector.tmp"
    mv "$views/detector.tmp" "$views/detector.json"
  fi
  fit="$work/$name/fit/$frame"
  mkdir -p "$work/$name/fit"
  rm -rf "$fit"
  "$bin/handscs-fit" --multiview "$views" --out "$fit" --threads 2 --log-level warn "$@" \
    > "$work/$name/fit/$frame.log" 2>&1 || echo "frame $frame: handscs-fit failed: $(tail -1 "$work/$name/fit/$frame.log")"
  report="$work/$name/$frame.json"
  if [ -f "$fit/capture.json" ]; then
    python3 "$here/detector_vs_truth.py" frame --capture "$capture" --frame "$frame" --multiview "$views" \
      --fit "$fit" --json "$report"
  else
    python3 "$here/detector_vs_truth.py" frame --capture "$capture" --frame "$frame" --multiview "$views" --json "$report"
  fi
  reports+=("$report")
done
python3 "$here/detector_vs_truth.py" table "${reports[@]}"
