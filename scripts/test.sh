#!/usr/bin/env bash
# Installs what is missing, builds the CI preset and runs the whole test suite.
#   scripts/test.sh [ctest arguments...]     e.g. scripts/test.sh -L dynamics
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/bootstrap.sh
cmake --preset ci
cmake --build --preset ci
# the Debian package (docs/packaging.md), which tests/packaging installs into a fresh Debian 12 root
cmake --build --preset ci --target package
ctest --preset ci --parallel "$(nproc)" "$@"
# the daemon's threads under ThreadSanitizer (a separate build); only for the whole suite
if (($# == 0)) && [[ "${HYQ_SKIP_TSAN:-0}" != 1 ]]; then scripts/tsan_check.sh; fi
