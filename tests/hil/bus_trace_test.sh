#!/usr/bin/env bash
# scripts/hil.sh --bus-trace and scripts/bus_trace_report.py.
#
#   bus_trace_test.sh BUILD_DIR SOURCE_DIR ARTIFACT_DIR   (inside tests/drivers/in_netns.sh)
#
# 1. The report on a hand-written trace whose answers are known: one answer late (it came after
#    the next SYNC), one cycle with an answer missing, latencies to the microsecond.
# 2. A 2 s lock-step HIL run recorded by hyq-candump on every bus, in which rf_hfe's board drops
#    two answers at 1 s: the SYNCs the recording holds are the SYNCs hyq-sim counted on each bus
#    (sim.json syncs_per_bus); every board's answers the recording finds missing (still missing
#    when the next SYNC went out) the daemon held (servod.json held_inputs per device), rf_hfe's
#    two dropped ones among them, and the late answers it finds the daemon discarded. The
#    daemon reads a little before it sends the next SYNC, so an answer that came in between is
#    held and then discarded late by the daemon but on time in the recording: on a quiet machine
#    the counts are equal, on a loaded one the recording's are at most the daemon's.
set -uo pipefail
build="${1:?}" src="${2:?}" art="${3:?}"
py=/usr/bin/python3
skip() { echo "SKIP: $*"; exit 77; }
fail() { echo "FAIL: $*"; exit 1; }
report="$src/scripts/bus_trace_report.py"
rm -rf "$art"; mkdir -p "$art/synthetic"

# --- 1. a hand-written trace (bus "x", boards 1 and 2; actuator TPDO: 16 bytes, counter at 14)
tpdo() { printf '(%s) x %03X##1%s%02X00\n' "$1" $((0x180 + $2)) "0000000000000000000000000000" "$3"; }
{
  echo "(100.000000) x 080#01"
  tpdo 100.000100 1 1; tpdo 100.000200 2 1
  echo "(100.001000) x 080#02"
  tpdo 100.001300 1 2                       # board 2 does not answer SYNC 2 in time ...
  echo "(100.002000) x 080#03"
  tpdo 100.002050 2 2                       # ... but after SYNC 3: late
  tpdo 100.002100 1 3; tpdo 100.002400 2 3
  echo "(100.003000) x 080#04"
} >"$art/synthetic/bus_x.log"
"$py" "$report" --json "$art/synthetic/report.json" "$art/synthetic" >"$art/synthetic/report.txt" \
  || fail "bus_trace_report.py exited $? on the hand-written trace"
cat "$art/synthetic/report.txt"
"$py" - "$art/synthetic/report.json" <<'PY' || fail "the report's numbers on the hand-written trace"
import json, sys
x = json.load(open(sys.argv[1]))["buses"]["x"]
want = dict(syncs=4, answers=5, late_answers=1, cycles_missing=1, longest_run=1,
            latency_p50_us=200.0, latency_max_us=400.0)
bad = {k: (x[k], v) for k, v in want.items() if x[k] != v}
print("bus_trace_test: hand-written trace:", x)
if bad:
    print("found / expected:", bad)
    sys.exit(1)
PY
"$py" "$report" "$art/nothing-here" >/dev/null 2>"$art/empty.err"
rc=$?
[[ $rc == 2 ]] || fail "an empty directory: exit $rc, expected 2"
grep -q "no bus_<name>.log" "$art/empty.err" || fail "an empty directory: no clear error ($(cat "$art/empty.err"))"

# --- 2. a recorded HIL run
[[ "${HYQ_NETNS:-}" == 1 ]] || skip "part 2: not in a private network namespace (tests/drivers/in_netns.sh could not unshare -n)"
HYQ_HIL_NETNS=1 "$src/scripts/hil.sh" --duration 2 --build "$build" --out "$art/run" --quiet --no-logger \
  --bus-trace --fault 1.0:drop:rf_hfe_joint:2 >"$art/run.out" 2>&1 || { cat "$art/run.out"; fail "scripts/hil.sh --bus-trace exited $?"; }
cat "$art/run.out"
for b in lf rf lh rh; do
  [[ -s "$art/run/bus_$b.log" ]] || fail "no trace of bus $b"
  cat "$art/run/bus_$b.err"
  grep -q "overflow 0," "$art/run/bus_$b.err" || fail "bus $b: the recorder lost datagrams (see above)"
done
grep -q "^  bus trace  " "$art/run.out" || fail "hil.sh's summary has no bus trace line"
"$py" "$report" --json "$art/run/report.json" "$art/run" >/dev/null || fail "bus_trace_report.py exited $?"
"$py" - "$art/run/report.json" "$art/run/sim.json" "$art/run/servod.json" <<'PY' || fail "the recording disagrees with hyq-sim or the daemon"
import json, sys
r = json.load(open(sys.argv[1]))["buses"]
sim = json.load(open(sys.argv[2])); s = json.load(open(sys.argv[3]))
ok = True
for b, n in sim["syncs_per_bus"].items():
    print(f"bus {b}: {r[b]['syncs']} SYNCs recorded, hyq-sim counted {n}; answers {r[b]['answers']}")
    ok &= r[b]["syncs"] == n and r[b]["answers"] > 0
h = s["held_inputs"]
names = {"1": "haa", "2": "hfe", "3": "kfe"}
rec = {}
for b, x in r.items():
    for node, n in x["missing_by_node"].items():
        if n:
            rec["imu" if node == "16" else f"{b}_{names[node]}"] = n
held = h["per_device"]
print(f"answers missing in the recording, per board: {rec}; held by the daemon: {held} (longest run {h['max_in_row']})")
for dev, n in rec.items():
    if n > held.get(dev, 0):
        print(f"  {dev}: {n} missing in the recording but {held.get(dev, 0)} held by the daemon"); ok = False
if rec.get("rf_hfe", 0) < 2 or held.get("rf_hfe", 0) < 2:
    print("  rf_hfe's two dropped answers are not in both"); ok = False
late = sum(x["late_answers"] for x in r.values())
print(f"late answers: {late} in the recording, {h['late_answers']} discarded by the daemon")
ok &= late <= h["late_answers"]
sys.exit(0 if ok else 1)
PY
echo "bus_trace_test: PASS"
