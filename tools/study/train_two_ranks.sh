#!/usr/bin/env bash
# One handscs-train run on 2 ranks over c10d on loopback, 1 thread each (docs/BENCHMARKS.md
# "Data-parallel training"); rank 1 takes its config from rank 0. Shared by the benchmarks that
# time such runs (bench-data-parallel.sh, time_to_quality.sh).
# Usage: tools/study/train_two_ranks.sh BIN RUN [rank 0's handscs-train options, --out RUN among them]
#   Rank 0 logs to RUN.log, rank 1 to RUN.rank1.log. Exits 0 when both ranks do; otherwise names
#   the failing rank's log on stderr and exits with its code.
set -uo pipefail
if [ $# -lt 2 ] || [ "$1" = "-h" ] || [ "$1" = "--help" ]; then sed -n 2,7p "$0"; exit 0; fi
bin="$1"
run="$2"
shift 2
# A port nobody listens on: the rendezvous of this run.
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
RANK=1 WORLD_SIZE=2 MASTER_PORT=$port "$bin/handscs-train" --out "$run" --threads 1 \
  > "$run.rank1.log" 2>&1 &
rank1=$!
RANK=0 WORLD_SIZE=2 MASTER_PORT=$port "$bin/handscs-train" "$@" --threads 1 > "$run.log" 2>&1
rank0_code=$?
wait $rank1
rank1_code=$?
if [ $rank0_code -ne 0 ]; then echo "train_two_ranks: rank 0 failed ($rank0_code): $run.log" >&2; exit $rank0_code; fi
if [ $rank1_code -ne 0 ]; then echo "train_two_ranks: rank 1 failed ($rank1_code): $run.rank1.log" >&2; exit $rank1_code; fi
