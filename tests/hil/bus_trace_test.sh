#!/usr/bin/env bash
# scripts/hil.sh --bus-trace and scripts/bus_trace_report.py.
#
#   bus_trace_test.sh BUILD_DIR SOURCE_DIR ARTIFACT_DIR   (inside tests/drivers/in_netns.sh)
#
# 1. The report on a hand-written trace whose answers are known: one answer late (it came after
#    the next SYNC), one cycle with an answer missing, latencies to the microsecond.
# 2. A 2 s lock-step HIL run recorded by hyq-candump on every bus, in which rf_hfe's board drops
#    two answers at 1 s: the SYNCs the recording holds are the SYNCs hyq-sim counted on each bus
#    (sim.json syncs_per_bus); the cycles it finds with an answer missing are the inputs the
#    daemon held (servod.json held_inputs: rf_hfe 2, two in a row), and its late answers the ones
#    the daemon discarded.
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
missing = {b: x["cycles_missing"] for b, x in r.items() if x["cycles_missing"]}
print(f"cycles with an answer missing in the recording: {missing}, longest run on rf {r['rf']['longest_run']}; "
      f"held by the daemon: {h['per_device']}, longest run {h['max_in_row']}")
ok &= missing == {"rf": 2} and r["rf"]["longest_run"] == 2 and h["per_device"] == {"rf_hfe": 2} and h["max_in_row"] == 2
late = sum(x["late_answers"] for x in r.values())
print(f"late answers: {late} in the recording, {s['held_inputs']['late_answers']} counted by the daemon")
ok &= late == s["held_inputs"]["late_answers"]
sys.exit(0 if ok else 1)
PY
echo "bus_trace_test: PASS"
