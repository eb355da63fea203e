#!/usr/bin/env bash
# The main job: installs what is missing, builds the release preset and runs the demo.
# Until the servo daemon and the simulated HyQ exist this is the dynamics demo.
#   scripts/run.sh [demo arguments...]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/bootstrap.sh
cmake --preset release
cmake --build --preset release
exec build/release/tools/hyq-dynamics-demo/hyq-dynamics-demo "$@"
