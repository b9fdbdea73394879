#!/usr/bin/env bash
# Time to quality on the largest capture (docs/SCALING.md, "Time to quality"): how long training
# takes to come within DELTA dB of the PSNR it ends at, on one process with 2 threads and on 2
# ranks over c10d (1 thread each, the same number of training views).
#   single   1 process, 2 threads, STEPS steps, a checkpoint every STEPS/20
#   ranks2   2 processes on loopback, 1 thread each, STEPS/2 steps, a checkpoint every STEPS/40
# Every checkpoint is scored after all runs have trained (not timed) on EVAL_IMAGES held-out images,
# evenly spaced; TRAIN_ONLY=1 stops after the training, and a second call scores what is there.
# The time of a checkpoint is the training loop's wall time at its step (metrics.csv "seconds",
# rank 0; opening the capture excluded). Time to quality: the first checkpoint within DELTA dB of
# the single run's last checkpoint (both modes are read against that one target). Train on an idle
# machine; the scoring may share it.
# Writes OUT/<mode>/ (the run), OUT/<mode>.csv (step, seconds, PSNR, SSIM, LPIPS per checkpoint),
# OUT/time_to_quality.png / .pdf (PSNR and LPIPS against wall time) and prints one JSON per mode.
# Usage: tools/study/time_to_quality.sh OUT CAPTURE
#   env: STEPS (10000), SEED (0), MODES ("single ranks2"), EVAL_IMAGES (250), DELTA (0.2),
#        SET (more config keys, e.g. "data.held_out_poses=4"), BIN (build/bin),
#        HANDSCS_LPIPS_WEIGHTS (default ../shared/assets/lpips/lpips_alex_v0.1.pt)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
if [ $# -lt 2 ] || [ "$1" = "-h" ] || [ "$1" = "--help" ]; then sed -n 2,18p "$0"; exit 0; fi
out="$1"
capture="$2"
bin="${BIN:-$root/build/bin}"
steps="${STEPS:-10000}"
seed="${SEED:-0}"
modes="${MODES:-single ranks2}"
eval_images="${EVAL_IMAGES:-250}"
delta="${DELTA:-0.2}"
lpips="${HANDSCS_LPIPS_WEIGHTS:-$root/../shared/assets/lpips/lpips_alex_v0.1.pt}"
read -r -a extra_set <<< "${SET:-}"
checkpoints=20  # checkpoints per run: the time to quality is resolved to 5% of the budget
if [ ! -f "$capture/annotations/test/InterHand2.6M_test_data.json" ]; then
  echo "time_to_quality: $capture: not an InterHand2.6M-layout capture (no annotations/test)" >&2
  exit 2
fi
[ -f "$lpips" ] || { echo "time_to_quality: $lpips: no LPIPS weights" >&2; exit 2; }
mkdir -p "$out"

failed() {  # $1 the log of a program that failed: its last lines, then stop
  echo "time_to_quality: failed; the end of $1:" >&2
  tail -n 3 "$1" >&2
  exit 1
}

steps_of() {  # $1 mode: its training steps (2 ranks render 2 views a step)
  case "$1" in
    single) echo "$steps" ;;
    ranks2) echo $(( steps / 2 )) ;;
    *) echo "time_to_quality: unknown mode $1" >&2; exit 2 ;;
  esac
}

train() {  # $1 mode, $2 run folder
  local mode="$1" run="$2" n every
  n=$(steps_of "$mode")
  every=$(( n / checkpoints ))
  local common=(--config "$root/configs/demo.json" --out "$run" --set "data.root=$capture"
                "model.seed=$seed" "train.seed=$seed" "train.iterations=$n"
                "train.checkpoint_every=$every" train.keep_checkpoints=0 "train.log_every=$every"
                train.validate_every=0 "eval.lpips.weights=$lpips" "${extra_set[@]}")
  if [ "$mode" = single ]; then
    "$bin/handscs-train" "${common[@]}" --threads 2 > "$run.log" 2>&1 || failed "$run.log"
  else
    "$root/tools/study/train_two_ranks.sh" "$bin" "$run" "${common[@]}" || failed "$run.log"
  fi
}

score() {  # $1 mode, $2 run folder: one CSV line per checkpoint
  local mode="$1" run="$2" csv="$out/$1.csv"
  echo "step,seconds,psnr,ssim,lpips" > "$csv.tmp"
  for ckpt in "$run"/checkpoints/step_*.ckpt; do
    local step; step=$(basename "$ckpt" .ckpt); step=$((10#${step#step_}))
    local dir="$run/eval_$step"
    [ -f "$dir/summary.json" ] || "$bin/handscs-eval" --checkpoint "$ckpt" --out "$dir" \
      --threads 2 --max-images "$eval_images" --no-regions --lpips-weights "$lpips" \
      > "$dir.log" 2>&1 || failed "$dir.log"
    python3 - "$run/metrics.csv" "$step" "$dir/summary.json" >> "$csv.tmp" <<'EOF'
import csv, json, sys
metrics, step, summary = sys.argv[1], int(sys.argv[2]), sys.argv[3]
seconds = next(float(r['seconds']) for r in csv.DictReader(open(metrics)) if int(r['iteration']) == step)
s = json.load(open(summary))['summary']
print(f"{step},{seconds:.1f},{s['psnr']:.4f},{s['ssim']:.5f},{s['lpips']:.5f}")
EOF
  done
  sort -t, -k1,1n "$csv.tmp" | uniq > "$csv" && rm "$csv.tmp"
}

# Every run trains before any is scored, so the timed part can have the machine to itself.
for mode in $modes; do
  run="$out/$mode"
  n=$(steps_of "$mode")
  if [ ! -f "$run/checkpoints/step_$(printf %08d "$n").ckpt" ]; then  # a finished run is kept
    rm -rf "$run"
    train "$mode" "$run"
  fi
done
[ "${TRAIN_ONLY:-0}" = 1 ] && exit 0
for mode in $modes; do score "$mode" "$out/$mode"; done

[ -f "$out/single.csv" ] || { echo "time_to_quality: no single run to set the target" >&2; exit 1; }
/usr/bin/python3 - "$out" "$delta" $modes <<'EOF'
import csv, json, sys
out, delta, modes = sys.argv[1], float(sys.argv[2]), sys.argv[3:]
rows = {m: list(csv.DictReader(open(f'{out}/{m}.csv'))) for m in modes}
target = float(rows['single'][-1]['psnr']) - delta
for m in modes:
    hit = next((r for r in rows[m] if float(r['psnr']) >= target), None)
    last = rows[m][-1]
    print(json.dumps({'mode': m, 'final_step': int(last['step']), 'final_seconds': float(last['seconds']),
                      'final_psnr': float(last['psnr']), 'target_psnr': round(target, 4),
                      'step_to_target': int(hit['step']) if hit else None,
                      'seconds_to_target': float(hit['seconds']) if hit else None}))
try:  # the curves, when Debian's matplotlib is there (python3-matplotlib)
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
except ImportError:
    sys.exit(0)
fig, (ax_psnr, ax_lpips) = plt.subplots(1, 2, figsize=(10, 4))
labels = {'single': '1 process, 2 threads', 'ranks2': '2 ranks (c10d), 1 thread each'}
for m in modes:
    t = [float(r['seconds']) for r in rows[m]]
    ax_psnr.plot(t, [float(r['psnr']) for r in rows[m]], 'o-', ms=3, label=labels.get(m, m))
    ax_lpips.plot(t, [float(r['lpips']) for r in rows[m]], 'o-', ms=3, label=labels.get(m, m))
ax_psnr.axhline(target, color='grey', ls='--', lw=1, label=f'{delta} dB below the 1-process end')
ax_psnr.set(xlabel='training wall time (s)', ylabel='held-out PSNR (dB)')
ax_lpips.set(xlabel='training wall time (s)', ylabel='held-out LPIPS')
ax_psnr.legend(fontsize=8)
ax_lpips.legend(fontsize=8)
fig.tight_layout()
for ext in ('png', 'pdf'):
    fig.savefig(f'{out}/time_to_quality.{ext}', dpi=110)
EOF
