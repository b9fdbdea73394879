#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite with ctest: every label, the
# study tools' tests (label "study") too. Arguments go to ctest (e.g. -LE study, -R install).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/install-deps.sh"
"$root/scripts/build.sh"
cd "$root/build"
ctest --output-on-failure --timeout 900 "$@"
