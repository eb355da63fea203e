#!/usr/bin/env bash
# Thread-sanitizer run over the daemon's threads (servo, telemetry, main/signals): builds
# hyq-servod, the telemetry tests and the simulated robot's tests with the tsan preset, runs the
# telemetry/ring tests and hyq-sim's real-time loop (stepping thread and bus thread), then a
# 3 s HIL trot (release hyq-sim, tsan hyq-servod, command channel on) and fails on any
# ThreadSanitizer report. The tsan build is ~10x slower, so the deadline policy is relaxed for
# this run only (the safety would otherwise, rightly, stop the robot).
#   scripts/tsan_check.sh        (scripts/test.sh runs it unless HYQ_SKIP_TSAN=1)
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-}" in -h|--help) sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;; esac
release="${HYQ_RELEASE_BUILD:-build/ci}"
cmake --preset tsan >/dev/null
cmake --build --preset tsan --target hyq-servod telemetry_test spsc_ring_test hil_test
# (the command-channel test rate-limits on the wall clock: under TSan it may get one retry)
ctest --test-dir build/tsan -R "Telemetry|SpscRing|CommandChannel|SimulatedRobot\.RealTime" \
  --output-on-failure --repeat until-pass:2
out=build/tsan/tsan-hil
mkdir -p "$out"
cfg="$PWD/build/tsan/tsan_servo.yaml"
sed -e "s|^  urdf: .*|  urdf: $PWD/config/robots/hyq.urdf|" -e "s|^  hal: .*|  hal: $PWD/config/hyq_hal.yaml|" \
  -e "s|^    time_budget_us: .*|    time_budget_us: 5000|" config/hyq_servo_sim.yaml > "$cfg"
printf 'deadline:\n  budget_fraction: 1.0\n  max_consecutive_misses: 1000\n' >> "$cfg"
rm -f "$out/command.key"
"$release/tools/hyq-command/hyq-command" --generate-key "$out/command.key" >/dev/null
# This run looks for races, not for tracking: on a slow 2-core machine the TSan build can miss
# hundreds of cycles in a row and the safety then stops the robot on a fault (exit 3), which is
# the daemon doing its job. Exit 66 is TSan's own; anything else (a crash, a signal) fails.
set +e
TSAN_OPTIONS="halt_on_error=0 exitcode=66" scripts/hil.sh --build "$release" \
  --servod-bin build/tsan/tools/hyq-servod/hyq-servod --out "$out" --duration 3 --quiet \
  --servod-arg --config --servod-arg "$cfg" --servod-arg --commands \
  --servod-arg --command-key --servod-arg "$out/command.key"
rc=$?
set -e
case "$rc" in
  0) ;;
  3) echo "tsan_check: note: the TSan daemon stopped on a fault (exit 3; too slow for the trot under TSan), its threads ran until then" ;;
  4) echo "tsan_check: note: the robot fell under the TSan daemon (too slow for the trot under TSan)" ;;
  66) echo "tsan_check: FAIL: ThreadSanitizer exit code 66" >&2 ;;
  *) echo "tsan_check: FAIL: hil.sh exited $rc (see $out/servod.log)" >&2; exit 1 ;;
esac
if [[ "$rc" == 66 ]] || grep -q "WARNING: ThreadSanitizer" "$out/servod.log"; then
  grep -A20 "WARNING: ThreadSanitizer" "$out/servod.log" | head -60
  echo "tsan_check: FAIL: ThreadSanitizer reports in $out/servod.log" >&2
  exit 1
fi
echo "tsan_check: PASS (no ThreadSanitizer report over a 3 s HIL trot; telemetry tests clean)"
