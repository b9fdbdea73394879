#!/usr/bin/env bash
# Data-parallel training on one machine (docs/BENCHMARKS.md "Data-parallel training"):
# the same number of training views three ways, each seed trained and scored as the ablation is.
#   single   1 process, 2 threads, batch_size 1, VIEWS steps        (today's default)
#   batch2   1 process, 2 threads, batch_size 2, VIEWS/2 steps
#   ranks2   2 processes (c10d on loopback), 1 thread each, batch_size 1, VIEWS/2 steps
# Protocol (fixed before the first run): `real_demo` capture, configs/demo.json with LPIPS (loss and
# metric) and no validation renders, seeds 0 1 2, VIEWS = 2000, novel-pose PSNR/SSIM/LPIPS over 150 held-out images; the
# training loop's own wall time (rank 0's "N steps in S s" line, capture opening excluded).
# Prints one JSON object per run and writes OUT/results.csv. Run it on an idle machine.
# Usage: tools/study/bench-data-parallel.sh OUT [CAPTURE]   (CAPTURE: a real_demo capture to reuse)
#   env: SEEDS (default "0 1 2"), VIEWS (2000), MODES ("single batch2 ranks2"), BIN (build/bin),
#        HANDSCS_LPIPS_WEIGHTS (default ../shared/assets/lpips/lpips_alex_v0.1.pt)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
if [ $# -lt 1 ] || [ "$1" = "-h" ] || [ "$1" = "--help" ]; then sed -n 2,14p "$0"; exit 0; fi
out="$1"
capture="${2:-$out/capture}"
bin="${BIN:-$root/build/bin}"
seeds="${SEEDS:-0 1 2}"
views="${VIEWS:-2000}"
modes="${MODES:-single batch2 ranks2}"
lpips="${HANDSCS_LPIPS_WEIGHTS:-$root/../shared/assets/lpips/lpips_alex_v0.1.pt}"
eval_images=150  # as the ablation sweeps (configs/sweeps/ablation_real*.json)
mkdir -p "$out"
if [ ! -f "$capture/annotations/test/InterHand2.6M_test_data.json" ]; then
  "$bin/handscs-synth" --preset real_demo --out "$capture" --threads 2
fi
lpips_set=()
[ -f "$lpips" ] && lpips_set=("eval.lpips.weights=$lpips")

# "<steps> steps in <seconds> s (<rate> views/s)" and "<mb> MB exchanged per step, <ms> ms per step"
loop_seconds() { sed -n 's/.* steps in \([0-9.]*\) s (.*/\1/p' "$1" | tail -1; }
comm_field() { sed -n "s/.*data parallel: \([0-9.]*\) MB exchanged per step, \([0-9.]*\) ms per step.*/\\$2/p" "$1" | tail -1; }

csv="$out/results.csv"
[ -f "$csv" ] || echo "mode,seed,processes,threads_each,batch_size,steps,views,loop_s,views_per_s,comm_mb_per_step,comm_ms_per_step,psnr,ssim,lpips" > "$csv"
for seed in $seeds; do
  for mode in $modes; do
    run="$out/$mode.s$seed"
    if grep -q "^$mode,$seed," "$csv"; then echo "$mode seed $seed: already in $csv" >&2; continue; fi
    rm -rf "$run"
    common=(--config "$root/configs/demo.json" --out "$run" --set "data.root=$capture"
            "model.seed=$seed" "train.seed=$seed" train.validate_every=0 "${lpips_set[@]}")
    case "$mode" in
      single) steps=$views; batch=1; processes=1; threads=2
              "$bin/handscs-train" "${common[@]}" "train.iterations=$steps" --threads 2 > "$run.log" 2>&1 ;;
      batch2) steps=$(( views / 2 )); batch=2; processes=1; threads=2
              "$bin/handscs-train" "${common[@]}" "train.iterations=$steps" train.batch_size=2 \
                --threads 2 > "$run.log" 2>&1 ;;
      ranks2) steps=$(( views / 2 )); batch=1; processes=2; threads=1
              "$root/tools/study/train_two_ranks.sh" "$bin" "$run" "${common[@]}" \
                "train.iterations=$steps" ;;
      *) echo "bench-data-parallel: unknown mode $mode" >&2; exit 2 ;;
    esac
    seconds=$(loop_seconds "$run.log")
    mb=$(comm_field "$run.log" 1); ms=$(comm_field "$run.log" 2)
    "$bin/handscs-eval" --checkpoint "$run" --out "$run/eval" --threads 2 \
      --max-images "$eval_images" > "$run.eval.log" 2>&1
    read -r psnr ssim lp < <(python3 -c 'import json,sys; s=json.load(open(sys.argv[1]))["summary"]; print(s["psnr"], s["ssim"], s.get("lpips", "nan"))' "$run/eval/summary.json")
    rate=$(python3 -c "print(round($views / $seconds, 2))")
    echo "$mode,$seed,$processes,$threads,$batch,$steps,$views,$seconds,$rate,${mb:-0},${ms:-0},$psnr,$ssim,$lp" >> "$csv"
    echo "{\"mode\": \"$mode\", \"seed\": $seed, \"processes\": $processes, \"views\": $views, \"loop_s\": $seconds, \"views_per_s\": $rate, \"comm_mb_per_step\": ${mb:-0}, \"comm_ms_per_step\": ${ms:-0}, \"psnr\": $psnr, \"ssim\": $ssim, \"lpips\": $lp}"
  done
done
