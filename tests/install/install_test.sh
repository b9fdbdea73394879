#!/usr/bin/env bash
# The programs as installed (ctest "install: install_test"): `cmake --install` into a temporary
# prefix outside the repository, then, from a folder there, the installed programs with the
# installed tiny config: handscs-bench runs a one-run sweep on a tiny capture and draws its charts,
# handscs-features draws a tiny run's t-SNE plot. Each must log the script it ran from the prefix's
# share/handscs/scripts/, and a lone copy of handscs-bench with no share/ beside it must name the
# path it tried and draw nothing: the programs find their scripts beside themselves, never in the
# source tree.
#   install_test.sh BUILD_DIR
set -euo pipefail
build="$1"
source_tree="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd -P)"
work="$(mktemp -d "${TMPDIR:-/tmp}/handscs_install_test.XXXXXX")"
trap 'rm -rf "$work"' EXIT
work="$(cd "$work" && pwd -P)"  # as /proc/self/exe reports it
prefix="$work/prefix"
fail() {
  echo "install test: $*" >&2
  exit 1
}
# A PNG file's signature.
is_png() { [ "$(head -c 8 "$1" 2>/dev/null | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ]; }

cmake --install "$build" --prefix "$prefix" > "$work/install.log" 2>&1 || {
  cat "$work/install.log"
  fail "cmake --install $build failed"
}
scripts="$prefix/share/handscs/scripts"
for file in bin/handscs-bench bin/handscs-features bin/handscs-train bin/handscs-synth bin/handscs-eval \
            share/handscs/scripts/plot_sweep.py share/handscs/scripts/plot_features.py \
            share/handscs/scripts/convert_mano.py share/handscs/scripts/convert_lpips_weights.py \
            share/handscs/scripts/detect_landmarks.sh share/handscs/scripts/detect_landmarks.mjs \
            share/handscs/scripts/capture_to_multiview.py \
            share/handscs/configs/base.json share/handscs/configs/tiny.json share/handscs/configs/sweeps/quick.json; do
  [ -f "$prefix/$file" ] || fail "$file is not installed in $prefix"
done
for script in "$scripts"/*; do
  [ ! -L "$script" ] || fail "$script is a link (into $(readlink "$script")), not a copy"
done
for program in "$prefix"/bin/*; do
  if grep -qaF "$source_tree/scripts" "$program"; then fail "$program names $source_tree/scripts"; fi
done

cd "$work"
"$prefix/bin/handscs-synth" --preset tiny --out capture --threads 1 --log-level warn > synth.log 2>&1 ||
  { cat synth.log; fail "handscs-synth failed"; }

# handscs-bench: a one-run sweep with the installed tiny config, trained and scored by the installed
# handscs-train and handscs-eval beside it, ending with its charts (its run is kept for below).
cat > sweep.json <<JSON
{"run_config": "$prefix/share/handscs/configs/tiny.json", "budgets": [10], "eval_images": 2, "threads": 1,
 "points": [{"name": "tiny", "set": ["train.log_every=5", "train.validate_every=0"]}]}
JSON
"$prefix/bin/handscs-bench" --sweep sweep.json --capture capture --out sweep --keep-runs > bench.log 2>&1 ||
  { cat bench.log; fail "handscs-bench failed"; }
grep -q "^tiny,10,.*,ok," sweep/results.csv || { cat sweep/results.csv bench.log; fail "the sweep's run is not ok"; }
grep -qF "drawing the charts with $scripts/plot_sweep.py" bench.log ||
  { cat bench.log; fail "handscs-bench did not run $scripts/plot_sweep.py"; }
is_png sweep/psnr_vs_time.png || { cat bench.log sweep/logs/plots.log; fail "no chart sweep/psnr_vs_time.png"; }
echo "handscs-bench: $(grep -F "drawing the charts" bench.log | sed 's/.*\] //'); psnr_vs_time.png $(stat -c %s sweep/psnr_vs_time.png) bytes"

# A copy without share/ beside it: the charts are skipped, naming the path tried.
mkdir -p lone/bin lone_sweep
cp "$prefix/bin/handscs-bench" lone/bin/
cp sweep/results.csv lone_sweep/
lone/bin/handscs-bench --plots-only --out lone_sweep > lone.log 2>&1 || { cat lone.log; fail "the lone handscs-bench failed"; }
grep -qF "plot_sweep.py not found: tried $work/lone/share/handscs/scripts/plot_sweep.py" lone.log ||
  { cat lone.log; fail "the lone handscs-bench did not name the path it tried"; }
[ ! -e lone_sweep/psnr_vs_time.png ] || fail "the lone handscs-bench drew a chart"
echo "lone handscs-bench: $(grep -F "not found" lone.log | sed 's/.*\] //')"

# handscs-features on the sweep's run.
"$prefix/bin/handscs-features" --checkpoint sweep/runs/tiny_10 --out features --num-poses 2 --threads 1 > features.log 2>&1 ||
  { cat features.log; fail "handscs-features failed"; }
grep -qF "$scripts/plot_features.py tsne" features.log ||
  { cat features.log; fail "handscs-features did not run $scripts/plot_features.py"; }
for picture in pca_grid tsne_decoder_input; do
  is_png "features/$picture.png" || { cat features.log; fail "no picture features/$picture.png"; }
done
echo "handscs-features: $(grep -F "running" features.log | grep -F tsne | sed 's/.*\] //'); tsne_decoder_input.png $(stat -c %s features/tsne_decoder_input.png) bytes"
# The README's `--config configs/tiny.json` from a folder without configs/: the message names the
# installed config to give instead of "cannot open file" alone.
if "$prefix/bin/handscs-train" --config configs/tiny.json --out relative_run --threads 1 > relative.log 2>&1; then
  fail "handscs-train ran without its config"
fi
grep -qF "configs/tiny.json: no such file in $work; the installed one is $prefix/share/handscs/configs/tiny.json (give that path)" relative.log ||
  { cat relative.log; fail "handscs-train did not name the installed config"; }
echo "a relative --config: $(grep -F "no such file" relative.log | sed 's/.*\] //')"
echo "install test: passed"
