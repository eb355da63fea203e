#!/usr/bin/env bash
# hyq-servod --check on good and bad configurations: a bad one exits non-zero with a message that
# names the file, the key and what was expected.
#   servod_check_test.sh HYQ_SERVOD SOURCE_DIR WORK_DIR
set -uo pipefail
servod=$1 src=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
cp "$src/config/hyq_hal.yaml" "$work/" && cp -r "$src/config/robots" "$work/"
good="$src/config/hyq_servo.yaml"
fails=0

expect_ok() {
  if out=$("$servod" --check --config "$1" 2>&1); then echo "ok   $1: $out"
  else echo "FAIL $1 should be valid: $out"; fails=$((fails + 1)); fi
}
# expect_error NAME 'sed program' 'text'...: the variant fails --check and names every text
expect_error() {
  local name=$1 prog=$2
  shift 2
  local f="$work/$name.yaml"
  sed "$prog" "$good" > "$f"
  cmp -s "$f" "$good" && { echo "FAIL $name: the sed program changed nothing"; fails=$((fails + 1)); return; }
  out=$("$servod" --check --config "$f" 2>&1)
  rc=$?
  if ((rc == 0)); then echo "FAIL $name: accepted"; fails=$((fails + 1)); return; fi
  for t in "$f" "$@"; do
    if [[ "$out" != *"$t"* ]]; then echo "FAIL $name: message lacks '$t': $out"; fails=$((fails + 1)); return; fi
  done
  echo "ok   $name (exit $rc): $out"
}

expect_ok "$good"
expect_ok "$src/config/hyq_servo_sim.yaml"
expect_error syntax_error 's/^  kind: two_stage .*/  kind: [two_stage/' "not valid YAML" "expected well-formed YAML"
expect_error unknown_key 's/^  rate_hz: 1000 .*/  rate_hz: 1000\n  rate_khz: 1/' "key 'loop.rate_khz'" "expected one of the keys" "unknown key 'rate_khz'"
expect_error wrong_joint_count 's/^    kp_tau: [0-9.]*.*/    kp_tau: [300, 300, 300, 300, 300]/' "key 'controller.gains.kp_tau'" "12 numbers" "a list of 5"
expect_error impossible_bus_load 's/^  rate_hz: 1000 .*/  rate_hz: 4000/' "key 'loop.rate_hz'" "bus" "load"
expect_error negative_gain 's/^    kd_tau: [0-9.]*.*/    kd_tau: [8, -8, 8]/' "key 'controller.gains.kd_tau[1]'" "a value in [0, 200]" "'-8'"
expect_error unstable_gain 's/^    kd_acc: [0-9.]* .*/    kd_acc: 900/' "key 'controller.gains.kd_acc" "0.5/dt" "'900'"
expect_error no_position_gain 's/^    kp_tau: [0-9.]*.*/    kp_tau: 0/; s/^    kp_acc: [0-9.]*.*/    kp_acc: 0/' "key 'controller.gains'" "a position gain > 0"
expect_error bad_controller 's/^  kind: two_stage .*/  kind: mpc/' "key 'controller.kind'" "one of 'pid' 'noslip' 'stage1' 'two_stage'" "'mpc'"
expect_error bad_mu 's/^  mu: 0.6 .*/  mu: [0.6, 0.6, nan, 0.6]/' "key 'contact.mu[2]'" "a finite number"
expect_error missing_urdf 's|^  urdf: robots/hyq.urdf|  urdf: robots/nope.urdf|' "nope.urdf"
expect_error bad_lcm_url 's|^  lcm_url: .*|  lcm_url: tcp://host|' "key 'telemetry.lcm_url'" "udpm://"

# expect_hal_error NAME 'sed program' 'text'...: the same with the HAL file edited
expect_hal_error() {
  local name=$1 prog=$2
  shift 2
  local d="$work/$name"
  mkdir -p "$d" && cp -r "$src/config/robots" "$d/" && cp "$good" "$d/hyq_servo.yaml"
  sed "$prog" "$src/config/hyq_hal.yaml" > "$d/hyq_hal.yaml"
  cmp -s "$d/hyq_hal.yaml" "$src/config/hyq_hal.yaml" && { echo "FAIL $name: the sed program changed nothing"; fails=$((fails + 1)); return; }
  out=$("$servod" --check --config "$d/hyq_servo.yaml" 2>&1)
  rc=$?
  if ((rc == 0)); then echo "FAIL $name: accepted"; fails=$((fails + 1)); return; fi
  for t in "$@"; do
    if [[ "$out" != *"$t"* ]]; then echo "FAIL $name: message lacks '$t': $out"; fails=$((fails + 1)); return; fi
  done
  echo "ok   $name (exit $rc): $out"
}
# configurations --check must refuse, each naming the key and what it expected
expect_error regex_channel 's|^  channel: HYQ_COMMAND|  channel: "HYQ_.*"|' "commands.channel" "regular expression"
expect_error lcm_url_bad_group 's|^  lcm_url: .*|  lcm_url: "udpm://[[[::"|' "telemetry.lcm_url (group)" "multicast address"
expect_hal_error udp_bad_port 's|^    interface: can0|    interface: udp::99999|' "hyq_hal.yaml" "bus 'lf'" "1..65535" "99999"
expect_hal_error two_buses_one_port 's|^    interface: can0|    interface: udp|; s|^    interface: can1|    interface: udp::43113|' \
  "bus 'rf': expected a channel of its own" "udp:239.74.163.2:43113" "bus 'lf'"
expect_hal_error duplicate_bus_name 's|^  - name: rh$|  - name: lh|' "expected a unique bus name, found 'lh' a second time"
expect_hal_error missing_imu '/kind: imu/d' "expected exactly one IMU"
expect_hal_error nan_timeout 's|^  state_timeout_s: .*|  state_timeout_s: .nan|' "timing.state_timeout_s"
# the command key: with the channel on, a key others can read is refused by --check
printf '%064d\n' 0 > "$work/open.key" && chmod 644 "$work/open.key"
sed -e 's|^  enabled: false  *# the LCM command channel.*|  enabled: true|' -e "s|^  key_file: .*|  key_file: $work/open.key|" "$good" > "$work/open_key.yaml"
out=$("$servod" --check --config "$work/open_key.yaml" 2>&1); rc=$?
if ((rc == 1)) && [[ "$out" == *"open.key': expected mode 0600 or 0400"* ]]; then echo "ok   open_key: $out"
else echo "FAIL open_key (exit $rc): $out"; fails=$((fails + 1)); fi

# not a configuration file at all: a device, a directory (used to hang or abort)
for f in /dev/zero "$work"; do
  out=$(timeout 10 "$servod" --check --config "$f" 2>&1); rc=$?
  if ((rc == 1)) && [[ "$out" == *"expected a regular YAML file"* ]]; then echo "ok   config $f: $out"
  else echo "FAIL config $f (exit $rc): $out"; fails=$((fails + 1)); fi
done

# the host check: every item reported with a verdict; exit 0 when only warning, 4 with
# realtime.require_rt_host when an item is not ok (this machine's own verdicts decide which)
out=$("$servod" --check-host --check-host-seconds 0.2 --config "$good" 2>&1); rc=$?
items=0
for name in "kernel preemption" "servo CPU isolation" "servo CPU interrupts" "frequency governor" \
            "idle states" "memlock limit" "rtprio limit" "RT throttling" "wake-up latency"; do
  grep -qE "^\[ ?(ok|warn|FAIL) ?\] $name: " <<< "$out" && items=$((items + 1))
done
if ((rc == 0 && items == 9)); then echo "ok   --check-host: 9 items"; else echo "FAIL --check-host (exit $rc, $items of 9 items): $out"; fails=$((fails + 1)); fi
sed -e 's|^  require_rt_host: false|  require_rt_host: true|' "$good" > "$work/require_rt.yaml"
grep -q '^  require_rt_host: true' "$work/require_rt.yaml" || { echo "FAIL: no realtime.require_rt_host in $good"; fails=$((fails + 1)); }
out=$("$servod" --check-host --check-host-seconds 0.2 --config "$work/require_rt.yaml" 2>&1); rc=$?
if grep -qE "^\[ *(warn|FAIL)\]" <<< "$out"; then want=4; else want=0; fi
if ((rc == want)) && [[ "$out" == *"hyq-servod: host check: "* ]]; then
  echo "ok   --check-host with require_rt_host: exit $rc"
else echo "FAIL --check-host with require_rt_host (exit $rc, expected $want): $out"; fails=$((fails + 1)); fi
out=$("$servod" --check-host --check-host-seconds -1 2>&1); rc=$?
if ((rc == 2)) && [[ "$out" == *"--check-host-seconds"* ]]; then echo "ok   bad --check-host-seconds"
else echo "FAIL bad --check-host-seconds (exit $rc): $out"; fails=$((fails + 1)); fi

# bad command-line flags name the flag, what was expected and what was found
out=$("$servod" --clock warp 2>&1); rc=$?
if ((rc == 2)) && [[ "$out" == *"--clock"* && "$out" == *"realtime or lockstep"* && "$out" == *"warp"* ]]; then
  echo "ok   bad flag: $out"; else echo "FAIL bad flag (exit $rc): $out"; fails=$((fails + 1)); fi
"$servod" --help >/dev/null || { echo "FAIL --help"; fails=$((fails + 1)); }

((fails == 0)) && echo "servod_check_test: PASS" || echo "servod_check_test: $fails failure(s)"
exit $((fails > 0))
