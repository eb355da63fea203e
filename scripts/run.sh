#!/usr/bin/env bash
# The main job: installs what is missing, builds, then runs the daemon (hyq-servod) driving the
# simulated HyQ (hyq-sim) over virtual CAN in lock-step, in a private network namespace: it
# stands up, trots on mu = 0.1 with the two-stage ID, stops cleanly and prints a summary. The LCM
# log (hil-run/telemetry.lcmlog) is kept for lcm-spy (hyq-spy, lcm-logplayer-gui) or
#   build/ci/tools/hyq-lcm-export/hyq-lcm-export hil-run/telemetry.lcmlog hil-run/csv --plot
#
#   scripts/run.sh [--duration S] [hil.sh options...]      (default 5 s of trot)
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-}" in -h|--help) sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;; esac
# The same build tree as scripts/test.sh (the ci preset: Release, the flags the robot runs), but
# only what the main job runs: a later scripts/test.sh builds the rest of the tree on top of it.
preset="${HYQ_PRESET:-ci}"
scripts/bootstrap.sh
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" --target hyq-servod hyq-sim hyq-lcm-export hyq-command hyq_lcmtypes_gen
exec scripts/hil.sh --build "build/$preset" --out hil-run "$@"
