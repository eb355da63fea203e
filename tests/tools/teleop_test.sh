#!/usr/bin/env bash
# hyq-teleop in a terminal (tmux), inside a private network namespace (tests/drivers/in_netns.sh):
# keys change the commanded velocity within the limits, the screen shows it and the estimated
# velocity from HYQ_BASE_STATE (tests/tools/teleop_listener.cc publishes one, turned 90°), the
# listener authenticates every set-velocity command with the robot's key, they come at most at
# --rate, space stops, q quits and leaves the terminal as it was (canonical mode, echo).
#   teleop_test.sh HYQ_TELEOP TELEOP_LISTENER HYQ_COMMAND OUT_DIR
set -uo pipefail
teleop=$1 listener=$2 command=$3 out=$4
py=/usr/bin/python3
command -v tmux >/dev/null || { echo "SKIP: tmux is missing (apt-get install tmux; scripts/bootstrap.sh lists it)"; exit 77; }
[[ "${HYQ_NETNS:-0}" == 1 ]] || { echo "SKIP: no private network namespace (tests/drivers/in_netns.sh)"; exit 77; }
fail() { echo "teleop_test: FAIL: $*" >&2; tmux -S "$out/tmux.sock" kill-server 2>/dev/null; kill "$lis" 2>/dev/null; exit 1; }
rm -rf "$out"
mkdir -p "$out"
export TERM=xterm
"$command" --generate-key "$out/robot.key" >/dev/null || fail "hyq-command --generate-key"
"$listener" "$out/robot.key" "$out/received.txt" &
lis=$!
t=(tmux -S "$out/tmux.sock")
"${t[@]}" new-session -d -x 120 -y 16 \
  "'$teleop' --key '$out/robot.key' --sender op@teleop --rate 5; stty -a > '$out/stty_after.txt'; sleep 60"
screen() { "${t[@]}" capture-pane -p; }
# waits up to 5 s for the screen to show the text
expect_screen() {
  for _ in $(seq 50); do screen | grep -qF -- "$1" && { echo "teleop_test: ok   screen shows '$1'"; return 0; }; sleep 0.1; done
  screen; fail "the screen does not show '$1'"
}
expect_screen "commanded  vx +0.00 m/s  vy +0.00 m/s  wz +0.00 rad/s"
# the listener's base state: 0.123 m/s along world y with the base turned 90° is forward
expect_screen "estimated  vx +0.12 m/s  vy +0.00 m/s  wz +0.07 rad/s"
"${t[@]}" send-keys w w w Up a d d Left Left Right
expect_screen "commanded  vx +0.20 m/s  vy -0.05 m/s  wz +0.10 rad/s"
sleep 1
"${t[@]}" send-keys w w w w w w w w w w Down Up
expect_screen "commanded  vx +0.40 m/s  vy -0.05 m/s  wz +0.10 rad/s"   # clamped to --max
sleep 1
# keys faster than --rate: the changes are coalesced, the commands stay >= 0.2 s apart
for _ in 1 2 3 4 5 6; do "${t[@]}" send-keys s; sleep 0.04; done
expect_screen "commanded  vx +0.10 m/s  vy -0.05 m/s  wz +0.10 rad/s"
screen > "$out/screen.txt"
sleep 1
"${t[@]}" send-keys Space
expect_screen "commanded  vx +0.00 m/s  vy +0.00 m/s  wz +0.00 rad/s"
sleep 1
"${t[@]}" send-keys q
for _ in $(seq 50); do [[ -s "$out/stty_after.txt" ]] && break; sleep 0.1; done
expect_screen "hyq-teleop: sent "
screen | grep -F "hyq-teleop: sent "
grep -qE '(^| )icanon( |$)' "$out/stty_after.txt" && grep -qE '(^| )echo( |$)' "$out/stty_after.txt" \
  || fail "the terminal was not restored: $(cat "$out/stty_after.txt")"
echo "teleop_test: ok   after q the terminal is back in canonical mode with echo"
"${t[@]}" kill-server
kill -TERM "$lis"; wait "$lis"
cat "$out/received.txt"
"$py" - "$out/received.txt" <<'PY' || fail "the commands the listener received"
import sys
rows = [l.split() for l in open(sys.argv[1]) if l.strip()]
refused = [r for r in rows if r[0] != "ok"]
ok = [(int(r[1]), int(r[2]), float(r[3]), float(r[4]), float(r[5]), float(r[6])) for r in rows if r[0] == "ok"]
def check(cond, what):
    print(f"teleop_test: {'ok  ' if cond else 'FAIL'} {what}")
    return cond
good = check(not refused, "every datagram authentic and fresh (listener's CommandAuthenticator)")
good &= check(ok and all(k == 7 for k, *_ in ok), "all KIND_SET_VELOCITY (7)")
good &= check(all(b[1] > a[1] for a, b in zip(ok, ok[1:])), "sequences increase")
v = [tuple(round(x, 3) for x in r[2:5]) for r in ok]
good &= check((0.2, -0.05, 0.1) in v, "(0.20, -0.05, 0.10) was sent")
good &= check((0.4, -0.05, 0.1) in v, "(0.40, -0.05, 0.10) was sent (clamped)")
good &= check((0.1, -0.05, 0.1) in v, "(0.10, -0.05, 0.10) was sent (after six quick steps)")
good &= check(all(abs(a) <= 0.4 and abs(b) <= 0.2 and abs(c) <= 0.5 for a, b, c in v), "all within the limits")
good &= check(bool(v) and v[-1] == (0.0, 0.0, 0.0), "the last command is zero (space)")
gaps = [b[5] - a[5] for a, b in zip(ok, ok[1:])]
good &= check(not gaps or min(gaps) >= 0.2 - 0.03, f"at most 5 commands/s (smallest gap {min(gaps, default=0):.3f} s)")
sys.exit(0 if good else 1)
PY
echo "teleop_test: PASS"
