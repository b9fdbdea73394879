#!/usr/bin/env bash
# The speed-accuracy benchmark (docs/BENCHMARKS.md): builds, then runs handscs-bench on the `bench`
# capture. Usage:
#   scripts/bench.sh --quick            smoke sweep, under 20 minutes on 2 cores (out/bench-quick)
#   scripts/bench.sh                    the full sweep, hours; resumable (out/bench-full)
#   scripts/bench.sh --sweep FILE [--out DIR]   any sweep file (configs/sweeps/*.json)
# Rerunning with the same output folder resumes where it stopped. LPIPS weights are used (loss and
# metric) when the shared copy is beside the project, or from $HANDSCS_LPIPS_WEIGHTS.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
sweep="$root/configs/sweeps/full.json"
out=""
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) sweep="$root/configs/sweeps/quick.json" ;;
    --sweep) sweep="$2"; shift ;;
    --out) out="$2"; shift ;;
    -h|--help) sed -n 2,8p "$0"; exit 0 ;;
    *) echo "bench.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
  shift
done
[ -n "$out" ] || out="$root/out/bench-$(basename "$sweep" .json)"

"$root/scripts/install-deps.sh"
"$root/scripts/build.sh" handscs-synth handscs-train handscs-eval handscs-bench handscs-bench-raster
lpips="${HANDSCS_LPIPS_WEIGHTS:-$root/../shared/assets/lpips/lpips_alex_v0.1.pt}"
lpips_args=()
[ -f "$lpips" ] && lpips_args=(--lpips-weights "$lpips")

start=$(date +%s)
"$root/build/bin/handscs-bench" --sweep "$sweep" --out "$out" "${lpips_args[@]}"
echo "bench.sh: finished in $(( $(date +%s) - start )) s; results in $out:"
echo "  results.csv (one row per run), raster.csv, pareto.csv, summary.md, psnr_vs_time, lpips_vs_time,"
echo "  raster_ms_vs_n (.png and .pdf)"
cat "$out/summary.md"
