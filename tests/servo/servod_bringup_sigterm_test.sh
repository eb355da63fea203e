#!/usr/bin/env bash
# SIGTERM during the bring-up ends it at once (exit 1, the HAL's report), in lock-step and in
# real time, instead of after the bring-up timeout: no devices answer here, so the bring-up could
# only end by its timeout otherwise. Runs inside tests/drivers/in_netns.sh (multicast buses).
#   servod_bringup_sigterm_test.sh HYQ_SERVOD SOURCE_DIR OUT_DIR
set -uo pipefail
servod=$1 src=$2 out=$3
if [[ -z "${HYQ_NETNS:-}" ]]; then
  echo "servod_bringup_sigterm: SKIP: needs a private network namespace (tests/drivers/in_netns.sh)"
  exit 77
fi
mkdir -p "$out"
# fail LOG MESSAGE: prints the daemon's log, then the failure, and ends the test
fail() { cat "$1"; echo "FAIL: $2" >&2; exit 1; }
# stop_after CLOCK NAME DELAY: starts the daemon on the shipped simulation configuration with
# --clock CLOCK (stderr to $out/NAME.log), sends it SIGTERM after DELAY s; sets rc (its exit status)
# and ms (from the SIGTERM to the exit)
stop_after() {
  "$servod" --config "$src/config/hyq_servo_sim.yaml" --clock "$1" --no-telemetry --quiet \
    2>"$out/$2.log" &
  local pid=$! start
  sleep "$3"
  start=$(date +%s%N)
  kill -TERM "$pid"
  wait "$pid"
  rc=$?
  ms=$(( ($(date +%s%N) - start) / 1000000 ))
}
for clock in lockstep realtime; do
  stop_after "$clock" "$clock" 0.5
  echo "servod_bringup_sigterm: $clock: exit $rc, $ms ms after SIGTERM"
  [[ $rc -eq 1 ]] || fail "$out/$clock.log" "expected exit 1"
  ((ms < 2000)) || { echo "FAIL: the stop took $ms ms (the bring-up timeout is 3 s)" >&2; exit 1; }
  grep -q "bring-up aborted by a stop request" "$out/$clock.log" ||
    fail "$out/$clock.log" "no message naming the stop request"
done
# a SIGTERM 20 ms after the start, while the configuration and the URDF are still loading, is a
# stop request too (the signals are blocked from main's first line), not a kill
stop_after lockstep early 0.02
echo "servod_bringup_sigterm: SIGTERM during the start-up: exit $rc"
[[ $rc -eq 1 ]] || fail "$out/early.log" "expected exit 1 (143: killed by the signal)"
grep -q "bring-up aborted by a stop request" "$out/early.log" ||
  fail "$out/early.log" "no message naming the stop request"
# and without a signal, the lock-step bring-up ends after its bound in wall time (set to 3 s
# here), not after 3 s of simulated time at up to 200 ms of waiting per cycle (minutes)
source "$src/tests/support/sim_servo_config.sh"
sim_servo_config "$src" "$out/bringup3.yaml" "$src/config/hyq_hal.yaml" \
    -e 's|^  clock: lockstep .*|  clock: lockstep\n  lockstep_bringup_timeout_s: 3|'
start=$(date +%s%N)
"$servod" --config "$out/bringup3.yaml" --clock lockstep --no-telemetry --quiet 2>"$out/timeout.log"
rc=$?
ms=$(( ($(date +%s%N) - start) / 1000000 ))
echo "servod_bringup_sigterm: lock-step bring-up without devices: exit $rc after $ms ms"
[[ $rc -eq 1 ]] || fail "$out/timeout.log" "expected exit 1"
((ms < 8000)) || { echo "FAIL: the bring-up took $ms ms, the timeout is 3 s" >&2; exit 1; }
grep -q "timed out after 3 s of wall time" "$out/timeout.log" ||
  fail "$out/timeout.log" "the message does not name the wall time"
echo "servod_bringup_sigterm: PASS"
