#!/usr/bin/env bash
# lcm-spy (the project's hyq-spy launcher) under Xvfb watches a HIL run (scripts/hil.sh: hyq-sim +
# hyq-servod + lcm-logger) and must list every channel of the run with zero undecodable messages.
#
#   lcm_spy_test.sh BUILD_DIR SOURCE_DIR ARTIFACT_DIR        (run inside tests/drivers/in_netns.sh)
#
# What is checked is what lcm-spy itself shows: a Java agent (SpyTableProbe.java, compiled here and
# loaded into hyq-spy's JVM through JDK_JAVA_OPTIONS) reads lcm-spy's channel table on the Swing
# thread after the run. For each HYQ_* channel (JOINT_STATE, JOINT_TORQUE, BASE_STATE, CONTACT,
# FRICTION, DISTURBANCE, TIMING, HEALTH, EVENT) and for every channel lcm-logger recorded in the same run: the row exists,
# its Type is the expected hyq_lcm class (lcm-spy shows "?? <fingerprint>" for an unknown type),
# Num Msgs > 0, Undecodable = 0; and no row of the table at all is unknown or has decode errors.
# Artefacts: ARTIFACT_DIR/lcm_spy.png (screenshot of the Xvfb screen), lcm_spy_table.tsv, the logs.
# Exit 0 pass, 1 fail, 77 skipped (reason printed).
set -uo pipefail
build="${1:?build dir}" src="${2:?source dir}" art="${3:?artifact dir}"
skip() { echo "SKIP: $*"; exit 77; }
fail() { echo "FAIL: $*"; exit 1; }

[[ "${HYQ_NETNS:-}" == 1 ]] || skip "not in a private network namespace (tests/drivers/in_netns.sh could not unshare -n)"
for t in Xvfb java javac jar import; do
  command -v "$t" >/dev/null 2>&1 || skip "'$t' not found (Debian: xvfb, openjdk-17-jdk-headless, imagemagick)"
done
spy="$build/tools/hyq-spy/hyq-spy"
[[ -x "$spy" ]] || fail "$spy not built"
"$spy" --check >/dev/null 2>&1 || skip "hyq-spy --check: $("$spy" --check 2>&1 | tr '\n' ' ')"

mkdir -p "$art"
rm -f "$art"/lcm_spy.png "$art"/lcm_spy_table.tsv
work="$(mktemp -d /tmp/lcm_spy_test.XXXXXX)"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null; done
  rm -rf "$work"
}
trap cleanup EXIT

# the probe agent
mkdir -p "$work/probe"
javac -d "$work/probe" "$src/tests/hil/SpyTableProbe.java" || fail "javac SpyTableProbe.java"
printf 'Premain-Class: SpyTableProbe\n' >"$work/manifest.txt"
jar cfm "$work/probe.jar" "$work/manifest.txt" -C "$work/probe" . || fail "jar probe.jar"

# Xvfb on a free display (it picks the number itself and writes it to fd 3)
Xvfb -displayfd 3 -screen 0 1600x700x24 -nolisten tcp 3>"$work/display" 2>"$work/xvfb.log" &
pids+=($!)
for _ in $(seq 100); do [[ -s "$work/display" ]] && break; sleep 0.1; done
[[ -s "$work/display" ]] || skip "Xvfb did not start: $(tail -n 3 "$work/xvfb.log" | tr '\n' ' ')"
export DISPLAY=":$(head -1 "$work/display")"
echo "Xvfb on $DISPLAY"

# hyq-spy with the default URL, the probe loaded into its JVM
JDK_JAVA_OPTIONS="-javaagent:$work/probe.jar=$work/table.tsv,$work/stop" "$spy" >"$work/spy.log" 2>&1 &
spy_pid=$!
pids+=($spy_pid)
# wait for lcm-spy's window (it subscribes before it shows the window)
up=0
for _ in $(seq 300); do
  kill -0 "$spy_pid" 2>/dev/null || { cat "$work/spy.log"; fail "hyq-spy exited early"; }
  if command -v xwininfo >/dev/null 2>&1; then
    xwininfo -root -tree 2>/dev/null | grep -qi 'lcm spy' && { up=1; break; }
  elif ((SECONDS > 8)); then up=1; break; fi
  sleep 0.1
done
((up)) || { cat "$work/spy.log"; fail "lcm-spy window did not appear within 30 s"; }
sleep 0.5

# the HIL run, in this namespace (HYQ_HIL_NETNS=1: hil.sh does not unshare again)
HYQ_HIL_NETNS=1 "$src/scripts/hil.sh" --duration 2 --build "$build" --out "$work/hil" --quiet
hil_rc=$?
cp "$work/hil/servod.json" "$work/hil/servod.log" "$work/hil/sim.log" "$art/" 2>/dev/null
((hil_rc == 0)) || fail "scripts/hil.sh exited $hil_rc"
sleep 1.5   # lcm-spy's Hz thread refreshes the table once a second

import -display "$DISPLAY" -window root "$art/lcm_spy.png" || fail "import (screenshot) failed"
touch "$work/stop"
for _ in $(seq 150); do [[ -s "$work/table.tsv" ]] && break; sleep 0.1; done
[[ -s "$work/table.tsv" ]] || { cat "$work/spy.log"; fail "the probe did not dump lcm-spy's table"; }
cp "$work/table.tsv" "$art/lcm_spy_table.tsv"
cp "$work/spy.log" "$art/lcm_spy.log"
echo "screenshot: $art/lcm_spy.png"

/usr/bin/python3 - "$work/table.tsv" "$work/hil/telemetry.lcmlog" "$work/hil/servod.json" <<'PY'
import json, struct, sys
table_path, log_path = sys.argv[1], sys.argv[2]
cycles = json.load(open(sys.argv[3]))["cycles"]
print(f"the daemon ran {cycles} cycles (5 per-cycle channels; UDP receivers may miss some at "
      f"lock-step speed: counts are shown, not judged)")

# channels and counts in lcm-logger's file (event log format: sync, eventnum, utime, lengths)
logged = {}
with open(log_path, "rb") as f:
    data = f.read()
pos = 0
while pos + 28 <= len(data):
    sync, _ev, _ut, clen, dlen = struct.unpack_from(">IqqII", data, pos)
    if sync != 0xEDA1DA01:
        sys.exit(f"FAIL: {log_path}: bad sync word at byte {pos}")
    ch = data[pos + 28:pos + 28 + clen].decode()
    logged[ch] = logged.get(ch, 0) + 1
    pos += 28 + clen + dlen

lines = [l.rstrip("\n").split("\t") for l in open(table_path) if not l.startswith("#")]
# the held-input counts and their limit are fields of the HEALTH type lcm-spy decodes with
fields = {l.split()[2]: l.split()[3] for l in open(table_path) if l.startswith("# field ")}
for need, typ in (("held_inputs", "long[]"), ("max_held_in_row", "int[]"), ("max_held_cycles", "short")):
    if fields.get(need) != typ:
        sys.exit(f"FAIL: lcm-spy's lcmt_hyq_health has no field {need} ({typ}); fields: {sorted(fields)}")
print("lcm-spy's HYQ_HEALTH type carries held_inputs[], max_held_in_row[], max_held_cycles")
header, rows = lines[0], lines[1:]
col = {name: i for i, name in enumerate(header)}
for need in ("Channel", "Type", "Num Msgs", "Undecodable"):
    if need not in col:
        sys.exit(f"FAIL: lcm-spy's table has no column '{need}' (columns: {header})")
spy = {r[col["Channel"]]: r for r in rows}

expected = {"HYQ_JOINT_STATE": "lcmt_hyq_joint_state", "HYQ_JOINT_TORQUE": "lcmt_hyq_joint_torque",
            "HYQ_BASE_STATE": "lcmt_hyq_base_state", "HYQ_CONTACT": "lcmt_hyq_contact_state",
            "HYQ_TIMING": "lcmt_hyq_servo_timing", "HYQ_HEALTH": "lcmt_hyq_health",
            "HYQ_FRICTION": "lcmt_hyq_friction_estimate",
            "HYQ_DISTURBANCE": "lcmt_hyq_disturbance_estimate",
            "HYQ_EVENT": "lcmt_hyq_event"}
# LCM_SELF_TEST is liblcm-java's own start-up probe ("lcm self test" bytes, no type): lcm-spy's
# LCM instance sends it to itself once. It is not telemetry; it is shown but not judged.
SELF_TEST = "LCM_SELF_TEST"
problems = []
print(f"{'channel':18} {'lcm-spy type':24} {'spy msgs':>9} {'logged':>7} {'undecodable':>11}")
for ch in sorted(set(expected) | set(logged) | set(spy)):
    r = spy.get(ch)
    if r is None:
        problems.append(f"{ch}: not listed by lcm-spy (lcm-logger recorded {logged.get(ch, 0)})")
        continue
    typ, n, bad = r[col["Type"]], int(r[col["Num Msgs"]]), int(r[col["Undecodable"]])
    print(f"{ch:18} {typ:24} {n:9d} {logged.get(ch, 0):7d} {bad:11d}"
          + ("   (liblcm-java's start-up self test, not judged)" if ch == SELF_TEST else ""))
    if ch == SELF_TEST:
        continue
    if typ.startswith("??") or not typ:
        problems.append(f"{ch}: lcm-spy does not know its type ('{typ}')")
    elif ch in expected and typ != expected[ch]:
        problems.append(f"{ch}: type '{typ}', expected '{expected[ch]}'")
    if bad != 0:
        problems.append(f"{ch}: {bad} undecodable messages")
    if n <= 0:
        problems.append(f"{ch}: no messages")
    if ch not in logged and ch in expected:
        problems.append(f"{ch}: lcm-logger recorded nothing on it")
for p in problems:
    print("FAIL:", p)
if problems:
    sys.exit(1)
judged = sorted(c for c in spy if c != SELF_TEST)
print(f"PASS: lcm-spy lists all {len(judged)} channels of the run ({', '.join(judged)}), every one "
      f"decoded by its hyq_lcm type, 0 undecodable")
PY
