#!/usr/bin/env bash
# Configures and builds the project into build/ (Release): everything, or the targets named as
# arguments. Used by demo.sh (its four programs only) and test.sh (everything).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
jobs="${HANDSCS_BUILD_JOBS:-$(nproc)}"
# ccache: paths relative to the checkout, so a fresh clone elsewhere reuses earlier compilations.
export CCACHE_BASEDIR="$root"
# Ninja when there is no build folder yet (it schedules files of different libraries side by side;
# an existing folder keeps the generator it was configured with).
generator=()
if [ ! -f "$root/build/CMakeCache.txt" ] && command -v ninja >/dev/null; then generator=(-G Ninja); fi
cmake -S "$root" -B "$root/build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release >/dev/null
# Optional arguments name targets (e.g. the demo builds only the four programs it runs).
targets=()
for t in "$@"; do targets+=(--target "$t"); done
cmake --build "$root/build" -j "$jobs" "${targets[@]}"
