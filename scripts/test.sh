#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite with ctest: every label, the
# study tools' tests (label "study") too. Arguments go to ctest (e.g. -LE study, -R install).
# Each test program writes its scratch files under $TMPDIR/handscs_test_<pid>_<random>/ and removes them when
# it passes; after a failure they are kept and named (HANDSCS_KEEP_TEST_FILES=1 keeps them always).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/install-deps.sh"
"$root/scripts/build.sh"
cd "$root/build"
ctest --output-on-failure --timeout 900 "$@"
