#!/usr/bin/env bash
# docs/FIT.md, "One shape over a recorded sequence": the ten frames of detector_fit.sh's
# measurement as one multi-view sequence (a folder per instant beside the cameras), fitted by one
# handscs-fit --multiview, each frame's fitted joints against the true ones; prints the table, then
# the comparison with detector_fit.sh's run ALONE frame by frame.
#   detector_sequence.sh BIN_DIR WORK_DIR NAME ALONE [--set key=value ...]
# Run detector_fit.sh BIN_DIR WORK_DIR ALONE first: it makes the capture, the per-frame views and
# their landmarks. NAME's fit and reports go to WORK_DIR/NAME/.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
bin="$1"
work="$2"
name="$3"
alone="$4"
shift 4
# The frames detector_fit.sh made views of, in order.
mapfile -t frames < <(ls "$work/views" 2>/dev/null | grep -E '^[0-9]+$' | sort -n)
[ ${#frames[@]} -gt 0 ] || { echo "detector_sequence.sh: $work/views holds no frame: run detector_fit.sh first" >&2; exit 1; }

capture="$work/capture"
sequence="$work/sequence"
rm -rf "$sequence"
mkdir -p "$sequence"
# Every frame's views share the capture's cameras: one archive for the sequence.
ln -s "$(realpath "$work/views/${frames[0]}/cameras.npz")" "$sequence/cameras.npz"
for frame in "${frames[@]}"; do
  views="$work/views/$frame"
  [ -f "$views/detector.json" ] || { echo "detector_sequence.sh: $views has no landmarks: run detector_fit.sh first" >&2; exit 1; }
  # The same cameras, numbered alike (the archives' ZIP dates differ, so their arrays are compared).
  python3 -c 'import sys, zipfile
a, b = (zipfile.ZipFile(p) for p in sys.argv[1:3])
sys.exit(sorted(a.namelist()) != sorted(b.namelist()) or any(a.read(n) != b.read(n) for n in a.namelist()))' \
    "$views/cameras.npz" "$sequence/cameras.npz" && cmp -s "$views/views.json" "$work/views/${frames[0]}/views.json" ||
    { echo "detector_sequence.sh: $views: cameras differ from frame ${frames[0]}'s" >&2; exit 1; }
  mkdir -p "$sequence/$frame"
  ln -s "$(realpath "$views/img")" "$sequence/$frame/img"
  ln -s "$(realpath "$views/pose")" "$sequence/$frame/pose"
done
fit="$work/$name/fit"
mkdir -p "$work/$name"
rm -rf "$fit"
"$bin/handscs-fit" --multiview "$sequence" --out "$fit" --threads 2 --log-level warn "$@" > "$work/$name/fit.log" 2>&1 ||
  { echo "handscs-fit failed: $(tail -1 "$work/$name/fit.log")" >&2; exit 1; }
reports=()
for frame in "${frames[@]}"; do
  report="$work/$name/$frame.json"
  python3 "$here/detector_vs_truth.py" frame --capture "$capture" --frame "$frame" --multiview "$work/views/$frame" \
    --fit "$fit" --json "$report"
  reports+=("$report")
done
python3 "$here/detector_vs_truth.py" table "${reports[@]}"
echo
python3 "$here/detector_vs_truth.py" pair "$work/$alone" "$work/$name"
