#!/usr/bin/env bash
# End-to-end hardware-in-the-loop tests (label "hil"): the unmodified daemon (hyq-servod) and the
# simulated HyQ (hyq-sim) as separate processes on virtual CAN, through scripts/hil.sh.
#
#   hil_e2e_test.sh BUILD_DIR OUT_DIR trot
#       5 s of trot on mu = 0.1 with the two-stage ID in lock-step: the daemon stops cleanly, the
#       robot does not fall while ACTIVE, the mean tracking error <= 0.047 rad (1.5 x the untuned
#       gains' in-process 0.031 rad; with the shipped, tuned gains: 0.021 rad over 5 s, 0.034 rad
#       over 60 s), the trunk's roll and pitch RMS (truth) <= 1 deg, no deadline
#       fault (at most 5 single misses: see below), no fault event, and the LCM log decodes completely with our types.
#   hil_e2e_test.sh BUILD_DIR OUT_DIR fault SPEC REASON
#       the same trot with a fault injected by hyq-sim at 2.0 s (SPEC = KIND:TARGET[:ARG]): the
#       daemon reaches its safe state within 2 cycles of the fault reaching it (one period of
#       transport), with an event REASON; both processes end without a crash; the event is in
#       the LCM log.
#   hil_e2e_test.sh BUILD_DIR OUT_DIR realtime [DURATION]
#       the real-time clock (1 kHz, SCHED_FIFO daemon and plant) with the shipped configuration,
#       DURATION s (default 5) of trot on mu = 0.1 with the two-stage ID: no fault, ACTIVE
#       throughout, no fall, held inputs within their limit.
#   hil_e2e_test.sh BUILD_DIR OUT_DIR plant_stall
#       real time, shipped configuration: an 8 ms stall of hyq-sim's stepping thread while the
#       daemon trots; the boards answer from their own thread, so no fault; without that thread
#       (--bus-thread off) the same stall stops the daemon on input_missing.
#   hil_e2e_test.sh BUILD_DIR OUT_DIR compare
#       the shipped (tuned) PID and two-stage ID, 5 s of trot on mu = 0.1, lock-step,
#       on a plant that is not the model (hyq-sim --profile realistic --hydraulics off
#       --delay-cycles 0: payload, link errors of seed 1, joint friction, sensor biases; the
#       hydraulics and the extra cycle of delay make every tuned controller fault, see
#       docs/baselines.md): both stop cleanly without a fall, and the two-stage ID's mean tracking
#       error is below the PID's.
#   hil_e2e_test.sh BUILD_DIR OUT_DIR soak
#       the same for HYQ_SOAK_S seconds (default 600), only with HYQ_SOAK=1 (otherwise skipped, exit 77).
#   hil_e2e_test.sh BUILD_DIR OUT_DIR vcan
#       lock-step over SocketCAN (vcan0..3, CAN FD) inside ../shared/tools/run-in-vcan-vm when
#       this kernel has no vcan: bring-up, 0.3 s of standing with the two-stage ID, clean stop.
#   hil_e2e_test.sh BUILD_DIR OUT_DIR kill9
#       real time: the daemon trots, then dies by SIGKILL (no stop, no last frame): every board
#       drops its set-point on its own timer within 10 ms of its last SYNC / set-point
#       (docs/can_protocol.md), with no torque left on any joint.
#   hil_e2e_test.sh BUILD_DIR OUT_DIR commands
#       lock-step, the command channel on, no auto-enable: the daemon waits in STANDBY. An enable
#       signed with another key and an unsigned one change nothing; hyq-command with the robot's
#       key enables, and a damp from it stops the trot (docs/security.md).
#   hil_e2e_test.sh BUILD_DIR OUT_DIR steer
#       lock-step, mu = 0.8, the command channel on, auto-enable, 10 s of trot with the two-stage
#       ID steered by signed hyq-command set-velocity commands sent during the run, paced on the
#       simulated time (hyq-sim's truth file): 0.3 m/s forward at 3 s, then 0.2 m/s forward
#       turning at 0.4 rad/s at 6 s (the fixed forward profile before the first). At the end of
#       ACTIVE the base (hyq-sim's truth) is within 25 % of the commanded path's length of the
#       commanded position and within 0.2 rad of the commanded yaw (tests/hil/steered_run.py);
#       no fall, no fault, both commands applied (docs/steering.md).
#   hil_e2e_test.sh BUILD_DIR OUT_DIR recover
#       recovery after a degraded stop: a board silent for 0.5 s during the trot, the sit-down
#       into FAULT; hyq-command ack and enable; the robot stands up and trots again in the same
#       daemon, then stops under control (docs/servo.md, "Graded stops").
#   hil_e2e_test.sh BUILD_DIR OUT_DIR mainjob
#       the README's main-job command itself (scripts/run.sh), shortened to 1 s.
set -uo pipefail
build=$1 out=$2 mode=$3
shift 3
here="$(cd "$(dirname "$0")/../.." && pwd)"
py=/usr/bin/python3
fail() { echo "hil_e2e_test: FAIL: $*" >&2; exit 1; }
if [[ "$mode" == soak ]]; then  # the real-time soak (10 minutes, HYQ_SOAK_S): a benchmark, not for every run
  [[ "${HYQ_SOAK:-0}" == 1 ]] || { echo "SKIP: the 10-minute real-time soak runs only with HYQ_SOAK=1 (scripts/benchmark_servo.sh --soak)"; exit 77; }
  [[ "${HYQ_SOAK_S:-600}" =~ ^[1-9][0-9]*$ ]] || fail "HYQ_SOAK_S: expected whole seconds >= 1, found '${HYQ_SOAK_S}'"
  mode=realtime
  set -- "${HYQ_SOAK_S:-600}"
fi
rm -rf "$out"
mkdir -p "$out"

check_json() {  # python expression over s (servod.json), sim (sim.json), h (hil.json)
  "$py" - "$out" "$1" <<'PY' || exit 1
import json, os, sys
out, expr = sys.argv[1], sys.argv[2]
s = json.load(open(os.path.join(out, "servod.json")))
sim = json.load(open(os.path.join(out, "sim.json")))
h = json.load(open(os.path.join(out, "hil.json"))) if os.path.exists(os.path.join(out, "hil.json")) else {}
ok = eval(expr)
print(f"hil_e2e_test: {'ok  ' if ok else 'FAIL'} {expr}")
sys.exit(0 if ok else 1)
PY
}

decode_log() {
  "$build/tools/hyq-lcm-export/hyq-lcm-export" "$out/telemetry.lcmlog" "$out/csv" \
    || fail "the LCM log has undecodable messages (hyq-lcm-export)"
  for ch in JOINT_STATE JOINT_TORQUE BASE_STATE CONTACT FRICTION DISTURBANCE TIMING HEALTH EVENT; do
    [[ -s "$out/csv/HYQ_$ch.csv" ]] || fail "no HYQ_$ch messages in the LCM log"
  done
}

# stalled_by_the_machine RC DURATION: true when the run broke the trot's timing checks (stopped
# for its deadline policy, more than 1 % of the cycles over the deadline, or a fallback on the
# QP time budget) with a cycle or a QP over 1 ms (the whole period; the cycle's own work is at
# most ~0.5 ms, its QP stopping at its 400 us budget): the machine stalled the thread (seen on
# the shared 2-core VMs, 5-15 ms in bursts while the host steals time, and a lone 1.8 ms cycle
# beside a 642 us QP on CI), which says nothing about the run's
# subject. Prints the evidence (with_stall_retries below decides what follows). (The summary has
# no per-QP times: a genuine budget fallback in a run that also stalled elsewhere is repeated
# too, and must then not recur in the repeats.)
stalled_by_the_machine() {
  "$py" - "$out" "$1" "$2" <<'PY'
import json, os, re, sys
out, rc, dur = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
p = os.path.join(out, "servod.json")
if not os.path.exists(p): sys.exit(1)
s = json.load(open(p))
left = [e for e in s["event_log"] if e["from"] == "active"]
stopped = rc != 0 and left and left[0]["reason"] == "deadline_miss"
too_many = s["deadline_misses"] > 10 * dur or s["max_consecutive_misses"] >= 5
# a fallback on the QP time budget that the daemon did not itself classify as a stalled thread
# (DeadlineSpentByAStall), in a run with a cycle or QP over 1 ms
budget_fallback = s["controller_fallbacks_deadline"] > s["controller_fallbacks_deadline_stalled"]
if not (stopped or too_many or budget_fallback): sys.exit(1)
last = re.search(r"last ([0-9.]+) us", left[0]["detail"]) if stopped else None
worst = max(s["cycle_time"]["max_us"], s["qp_time_max_us"], float(last.group(1)) if last else 0.0)
print(f"hil_e2e_test: timing broken ({'stopped: ' + left[0]['detail'] if stopped else 'no stop'}; "
      f"{s['deadline_misses']} misses, at most {s['max_consecutive_misses']} in a row; "
      f"{s['controller_fallbacks_deadline']} fallbacks on the QP time budget), longest cycle or QP "
      f"{worst:.0f} us: " + ("the machine stalled the servo thread" if worst > 1000 else "not a stall of the machine"))
sys.exit(0 if worst > 1000 else 1)
PY
}

# relax_deadline FILE: appends the relaxed deadline policy (no stop for timing) to a servo
# configuration, for the runs that check something other than timing.
# real time, with HYQ_RT_PREFLIGHT=1 only: can this machine keep a 1 kHz SCHED_FIFO loop at all:
# 3 s of cyclictest, one thread per core the run uses; a wake-up later than the hold the daemon
# allows a missing answer: SKIP (exit 77). Off by default: with hyq-sim's bus thread and the
# daemon's answer wait the daemon rides through single stalls of either core far longer than the hold (the
# VM's 9-16 ms), and a run the machine did break is still recognised after it (below)
realtime_preflight() {
  hold_us=$((1000 * $(sed -n 's/^  max_held_cycles: *\([0-9]*\).*/\1/p' "$here/config/hyq_hal.yaml")))
  command -v cyclictest >/dev/null || return 0
  [[ "${HYQ_RT_PREFLIGHT:-0}" == 1 ]] || return 0
  local cpus=0 cyc worst
  (($(nproc) >= 2)) && cpus=0,1
  cyc=$(cyclictest -m -p 80 -i 1000 -d 0 -q -D 3 -t "$( [[ $cpus == 0 ]] && echo 1 || echo 2)" -a "$cpus" 2>&1)
  worst=$(sed -n 's/.*Max: *\([0-9]*\).*/\1/p' <<<"$cyc" | sort -n | tail -1)
  if [[ -n "$worst" ]]; then
    echo "hil_e2e_test: cyclictest (SCHED_FIFO 80, 1 kHz, 3 s, CPUs $cpus) before the run: worst wake-up $worst us (the hold: $hold_us us)"
    ((worst <= hold_us)) || { echo "SKIP: this machine cannot keep a 1 kHz SCHED_FIFO loop right now (cyclictest's worst wake-up $worst us is longer than the $hold_us us the daemon holds a missing answer): the real-time run would judge the machine, not the daemon"; exit 77; }
  else
    echo "hil_e2e_test: cyclictest could not run at SCHED_FIFO ($(head -c 200 <<<"$cyc" | tr '\n' ' ')); the run decides"
  fi
}

relax_deadline() {
  printf 'deadline:\n  budget_fraction: 1.0\n  max_consecutive_misses: 1000\n' >> "$1"
}

# servo_config FILE HAL [SED_ARG...]: the shipped simulation configuration, usable from FILE
source "$here/tests/support/sim_servo_config.sh"
servo_config() { sim_servo_config "$here" "$@"; }

# The first lines of a script run under unshare -n: the loopback up, carrying the multicast buses.
netns_script_head='#!/bin/bash
set -u
ip link set lo up; ip route add 224.0.0.0/4 dev lo'

# For the scripts that send commands during a run (TRUTH_CSV: hyq-sim's --truth file): the
# simulated time from its last complete row (the file is written as it runs, a few rows behind);
# lock-step runs 1-5x faster than the wall clock here, so commands are paced on the robot's time,
# not on sleeps. wait_sim T returns once the simulation reached T s, fails when the daemon
# ($servod) is gone or after a minute.
read -r -d '' sim_clock_functions <<'EOS'
simt() { tail -c 20000 "TRUTH_CSV" 2>/dev/null | tail -n 2 | head -n 1 | cut -d, -f1; }
wait_sim() {
  for i in $(seq 1200); do
    t=$(simt)
    [[ "$t" =~ ^[0-9.]+$ ]] && awk "BEGIN { exit !($t >= $1) }" && return 0
    kill -0 $servod 2>/dev/null || return 1
    sleep 0.05
  done
  return 1
}
EOS

# The shipped simulation configuration with the deadline policy relaxed; prints its path.
relaxed_deadline_config() {
  servo_config "$out/relaxed_servo.yaml" "$here/config/hyq_hal.yaml"
  relax_deadline "$out/relaxed_servo.yaml"
  echo "$out/relaxed_servo.yaml"
}

# with_stall_retries DURATION COMMAND...: runs COMMAND (a lock-step trot taking hil.sh options,
# sets rc) again while stalled_by_the_machine says the machine, not the daemon, broke its timing.
# After two such runs the third relaxes the deadline policy (timing_judged=0): the machine cannot
# judge the timing then, and everything else is still judged. A controller too slow on its own
# (cycles under 1 ms but over the deadline) is never rerun, so it still fails.
timing_judged=1
with_stall_retries() {
  local dur=$1 attempt
  shift
  for attempt in 1 2; do
    "$@"
    rc=$?
    stalled_by_the_machine "$rc" "$dur" || return 0
    echo "hil_e2e_test: running again (attempt $((attempt + 1)) of 3)"
  done
  echo "hil_e2e_test: the machine broke the timing twice: the third run relaxes the deadline policy and its timing is not judged"
  timing_judged=0
  "$@" --servod-arg --config --servod-arg "$(relaxed_deadline_config)"
  rc=$?
}

case "$mode" in
  trot)
    # DURATION s (default 5) of lock-step trot on mu = 0.1 with the two-stage ID; no QP of it
    # may fall back (a fallback is Stage I's torque or the contact-free ID)
    dur=${1:-5}
    with_stall_retries "$dur" "$here/scripts/hil.sh" --build "$build" --out "$out" --duration "$dur" --quiet
    cat "$out/servod.log" | tail -0
    [[ $rc -eq 0 ]] || { tail -n 20 "$out/servod.log" "$out/sim.log"; fail "hil.sh exit $rc"; }
    check_json "s['final_mode'] == 'stopped' and s['active_s'] >= $dur - 0.01"
    check_json 'not h["fell_while_active"]'
    check_json 'not sim["fell"]'   # after the stop either: it sits down
    check_json 's["tracking_error_mean_rad"] <= 1.5 * 0.031'
    # the trunk stays level while the reference runs (hyq-sim's truth; 0.26 / 0.27 deg measured)
    check_json 'h["trunk"]["roll_rms_deg"] <= 1.0 and h["trunk"]["pitch_rms_deg"] <= 1.0'
    # lock-step deadlines are the servo thread's CPU time; the loopback multicast's softirq work
    # (the other process's frames too) is charged to the sending thread now and then, a few ms
    # in one HAL write, and a busy sibling hyperthread slows the thread's own work (measured:
    # 0-5 cycles of 5000 on an idle VM, 18-20 beside the suite's fuzzers): no deadline fault, and
    # at most 1 % of the cycles over (a controller that is really too slow misses every cycle)
    if ((timing_judged)); then
      check_json "s['deadline_misses'] <= 10 * $dur and s['max_consecutive_misses'] < 5"
    else
      echo "hil_e2e_test: deadline misses not judged (relaxed run): $("$py" -c "import json; s = json.load(open('$out/servod.json')); print(s['deadline_misses'], 'misses, at most', s['max_consecutive_misses'], 'in a row')")"
    fi
    "$py" -c "import json; s = json.load(open('$out/servod.json')); print('hil_e2e_test: $dur s of trot, controller fallbacks', s['controller_fallbacks'], '(on the time budget:', s['controller_fallbacks_deadline'], ', of them a stalled thread:', s['controller_fallbacks_deadline_stalled'], '), QP time mean %.1f us max %.1f us' % (s['qp_time_mean_us'], s['qp_time_max_us']))"
    check_json 'set(s["events"]) <= {"bring_up_complete", "enable_command", "stop_request"}'
    check_json 'sim["lockstep_forced_steps"] == 0'
    decode_log
    # the fallbacks the telemetry caught (HYQ_CONTACT is decimated): stage, status, iterations
    "$py" - "$out/csv/HYQ_CONTACT.csv" <<'PY'
import csv, sys
names = ["optimal", "infeasible", "unbounded", "iteration_limit", "deadline", "bad_input"]
for r in csv.DictReader(open(sys.argv[1])):
    if int(r["fallback (enum)"]) != 0:
        print(f"hil_e2e_test: fallback at cycle {r['cycle (count)']}: Stage I {names[int(r['stage1_status (enum)'])]} "
              f"({r['stage1_iterations (count)']} it, {float(r['stage1_solve_us (us)']):.0f} us), Stage II "
              f"{names[int(r['stage2_status (enum)'])]} ({r['stage2_iterations (count)']} it, {float(r['stage2_solve_us (us)']):.0f} us)")
PY
    # none from a QP that ran out of iterations, none from
    # a QP too slow for its 400 us time budget (config/hyq_servo_sim.yaml; lock-step: the servo
    # thread's CPU time, qp/deadline.h). A fallback on the budget that a stalled thread caused
    # (the QP's own time under half or over 1.25x the budget: the VMs here deschedule a vCPU for
    # ms, which the guest charges to the thread's CPU time; 1 in 60 s seen beside a CPU hog,
    # its QP had run 17.7 us) is the machine's, counted apart, and allowed a few times. The
    # budget is timing: after two stalled runs (timing_judged=0) only the iterations are judged
    # The contact-aware trot with the delay-tuned gains has a degenerate Stage II now and then
    # (two stance feet on mu 0.1, 500-700 active-set iterations): 1-2 in 60 s run out of the
    # budget (2026-12-04 at 203887b); Stage I's torque takes over for that cycle. Up to 3 are
    # allowed and printed above; making that QP fast is the speed work's (docs/inverse_dynamics.md)
    check_json 's["controller_fallbacks"] == s["controller_fallbacks_deadline"]'
    if ((timing_judged)); then
      check_json 's["controller_fallbacks_deadline"] - s["controller_fallbacks_deadline_stalled"] <= 3'
      check_json 's["controller_fallbacks_deadline_stalled"] <= 5'
    fi
    ;;
  realtime)
    # the real-time clock with the SHIPPED configuration (config/hyq_servo_sim.yaml,
    # config/hyq_hal.yaml: no relaxed tolerance): the daemon's servo thread and hyq-sim's stepping
    # thread SCHED_FIFO (80 / 70), each on its own core, 1 kHz, DURATION s of trot on mu = 0.1
    # with the two-stage ID; no fault of any kind, the daemon ACTIVE the whole time, no fall
    dur=${1:-5}
    realtime_preflight
    "$here/scripts/hil.sh" --build "$build" --out "$out" --duration "$dur" --clock realtime --quiet
    rc=$?
    # a bring-up that timed out on lost inputs (no summary from the daemon) while the plant's
    # FIFO thread was itself stalled longer than the hold: the machine again (seen on CI, 30 % of
    # the answers missing during the bring-up)
    if [[ ! -s "$out/servod.json" && -s "$out/sim.json" ]] && grep -q "bring-up failed.*timed out" "$out/servod.log"; then
      grep -m1 "bring-up failed" "$out/servod.log"
      "$py" - "$out" "$hold_us" <<'PY' && { echo "SKIP: the daemon's bring-up timed out while the machine stalled the plant's real-time thread (see the line above): not judged"; exit 77; }
import json, os, sys
sim = json.load(open(os.path.join(sys.argv[1], "sim.json")))
p = sim["step_lateness"]
print(f"hil_e2e_test: plant step lateness during the bring-up: p99 {p['p99_us']:.0f} us, max {p['max_us']:.0f} us; "
      f"late steps {sim['late_steps']}, dropped {sim['dropped_steps']} (the hold: {sys.argv[2]} us)")
sys.exit(0 if p["max_us"] > float(sys.argv[2]) or sim["dropped_steps"] > 0 else 1)
PY
    fi
    if [[ -s "$out/sim.json" && -s "$out/servod.json" ]]; then
      # a machine that cannot keep real time itself cannot judge the daemon: when the FIFO
      # threads' own scheduling latency (the plant's step lateness, the servo's wake-up) is over
      # one period at the 99th percentile, the vCPUs were stalled (seen on this VM when the host
      # slowed it 2x); and when either thread was stalled once for longer than the hold the
      # daemon allows (timing.max_held_cycles periods: seen on the CI machine, one 4.6 ms stall
      # of the plant), a fault stop is the right answer to a robot that stopped answering. Then
      # the run is reported and skipped with its numbers, provided the daemon did stop safely.
      # A control fault (a joint out of range, a bad estimate, the controller's output) is put
      # down to the machine only when the machine stalled within the 0.1 s before it (skipped
      # periods or a late wake-up in the telemetry, HYQ_TIMING; or the plant's joint state
      # standing still across telemetry samples, HYQ_JOINT_STATE): a run-wide maximum is no alibi
      # (a touchdown that rang past 15 rad/s at 3.2 s was once excused by a 1.5 ms cycle).
      [[ -s "$out/telemetry.lcmlog" ]] && decode_log
      "$py" - "$out" "$rc" <<'PY' && { echo "SKIP: the machine did not keep real time during the run (see the line above); the daemon stopped safely (exit $rc), its tracking and events are not judged"; exit 77; }
import csv, json, os, sys
out = sys.argv[1]
s = json.load(open(os.path.join(out, "servod.json"))); sim = json.load(open(os.path.join(out, "sim.json")))
plant, wake = sim["step_lateness"], s["wakeup_latency"]
limit_us = 1000.0 * s["held_inputs"]["limit"]
faulted = int(sys.argv[2]) != 0 or not set(s["events"]) <= {"bring_up_complete", "enable_command", "stop_request", "damping_done"}
print(f"hil_e2e_test: scheduling latency at SCHED_FIFO during the run: plant step lateness p99 {plant['p99_us']:.0f} us max {plant['max_us']:.0f} us, "
      f"servo wake-up p99 {wake['p99_us']:.0f} us max {wake['max_us']:.0f} us (one period: 1000 us, the hold: {limit_us:.0f} us)")
cyc = s["cycle_time"]
print(f"hil_e2e_test: servo cycle time p99 {cyc['p99_us']:.0f} us max {cyc['max_us']:.0f} us (its work is ~0.2 ms: over a period, the VM took the core mid-cycle)")
stalled = (plant["p99_us"] > 1000 or wake["p99_us"] > 1000 or plant["max_us"] > limit_us or wake["max_us"] > limit_us
           or cyc["max_us"] > 1000)
if faulted and stalled and s["final_mode"] != "stopped":
    print(f"hil_e2e_test: FAIL: the machine stalled, but the daemon ended in {s['final_mode']!r}, not stopped")
    sys.exit(1)
control = [e for e in s["event_log"] if e["reason"] in ("out_of_range", "input_jump", "controller_failure", "estimator_failure")]
if faulted and stalled and control:
    c = control[0]["cycle"]
    timing = os.path.join(out, "csv", "HYQ_TIMING.csv")
    rows = []
    if os.path.exists(timing):
        for r in csv.DictReader(open(timing)):
            rows.append((int(r["cycle (count)"]), int(r["skipped_cycles (count)"]), int(r["wakeup_latency_ns (ns)"])))
    before = [r for r in rows if r[0] <= c - 100]
    window = [r for r in rows if c - 100 < r[0] <= c]
    skipped = (window[-1][1] - (before[-1][1] if before else 0)) if window else None
    late = max((r[2] for r in window), default=0) / 1e3
    # the plant's core stalled: the boards answered from the last physics step, so the joint
    # state stood still across two telemetry samples (4 cycles apart) while the robot moved
    frozen = 0
    state = os.path.join(out, "csv", "HYQ_JOINT_STATE.csv")
    if os.path.exists(state):
        prev = None
        for r in csv.DictReader(open(state)):
            k = int(r["cycle (count)"])
            q = tuple(v for name, v in r.items() if name.startswith("q_rad."))
            if c - 100 < k <= c and prev is not None and q == prev:
                frozen += 1
            prev = q
    print(f"hil_e2e_test: {control[0]['reason']} at cycle {c} ({control[0]['detail']}); in the 0.1 s before it: "
          f"{skipped if skipped is not None else 'unknown'} periods skipped, sampled wake-ups up to {late:.0f} us late, "
          f"{frozen} telemetry samples with the joint state of the sample before (the plant stood still)")
    if skipped is not None and skipped == 0 and late < 1000 and frozen == 0:
        print("hil_e2e_test: FAIL: a control fault with no stall of the machine before it: the control's, not the machine's")
        sys.exit(1)
sys.exit(0 if faulted and stalled else 1)
PY
    fi
    [[ $rc -eq 0 ]] || { tail -n 20 "$out/servod.log" "$out/sim.log"; fail "hil.sh --clock realtime exit $rc"; }
    grep -h "warning" "$out/servod.log" "$out/sim.log" | head -5
    "$py" - "$out" <<'PY'
import json, os, sys
out = sys.argv[1]
s = json.load(open(os.path.join(out, "servod.json"))); sim = json.load(open(os.path.join(out, "sim.json")))
w, k, hi = s["wakeup_latency"], s["control_time"], s["held_inputs"]
print(f"hil_e2e_test: real time {s['active_s']:.2f} s ACTIVE, mean error {s['tracking_error_mean_rad']:.4f} rad, "
      f"deadline misses {s['deadline_misses']} (max {s['max_consecutive_misses']} in a row), skipped {s['skipped_cycles']}, "
      f"held inputs {hi['total']} (longest {hi['max_in_row']} of {hi['limit']}), wake-up p99.9 {w['p999_us']:.0f} us max {w['max_us']:.0f} us, "
      f"ID mean {k['mean_us']:.1f} us max {k['max_us']:.0f} us; plant late steps {sim['late_steps']}, dropped {sim['dropped_steps']}")
PY
    check_json "s['final_mode'] == 'stopped' and s['active_s'] >= $dur - 0.01"
    check_json 'set(s["events"]) <= {"bring_up_complete", "enable_command", "stop_request", "damping_done"}'
    check_json 'not h["fell_while_active"]'
    check_json 's["held_inputs"]["max_in_row"] <= s["held_inputs"]["limit"]'
    check_json 's["tracking_error_mean_rad"] <= 1.5 * 0.031'
    # the plant's steps locked to the daemon's SYNC (hyq-sim --sync-phase, default 500 us): a
    # set-point acts from the next step, as in lock-step; free, the phase left the loop 1 ms more
    # delay in some runs, and that rang the rh knee at a touchdown (docs/benchmarks.md); locked
    # at least while ACTIVE (the steps before the daemon's first SYNC run free)
    check_json 'sim["sync_phase_us"] == 500 and sim["sync_phase_error"]["count"] >= 1000 * s["active_s"] and sim["sync_phase_error"]["p50_us"] <= 250'
    ;;
  plant_stall)
    # hyq-sim's stepping thread stalls for 8 ms of wall time (over twice the 3-cycle
    # hold) at 4 s of simulated time (--stall: what a preempted core does to the plant) in a
    # real-time run with the shipped configuration. The boards answer from their own thread (hyq-sim's bus thread) with the
    # last state there is, so the daemon holds nothing for long and trots on: no fault, and the
    # answers given during the stall are counted (sim.json stale_answers). Then the same run
    # with the stepping thread answering (--bus-thread off): the stall leaves the SYNCs
    # unanswered, and the daemon must stop on input_missing after its hold, which shows the
    # first run's pass is the bus thread's doing.
    realtime_preflight
    judge_machine() {  # $1 OUT, $2 rc [$3 the fault expected]: exit 77 when the servo's own
      # core stalled (late wake-ups, a cycle over a period) and it faulted on something else
      "$py" - "$1" "$2" "$hold_us" "${3:-}" <<'PY' && { echo "SKIP: the machine stalled the daemon's own core during the run (see the line above); not judged"; exit 77; }
import json, os, sys
s = json.load(open(os.path.join(sys.argv[1], "servod.json")))
w, c = s["wakeup_latency"], s["cycle_time"]
first = [e["reason"] for e in s["event_log"] if e["from"] == "active"][:1]
faulted = int(sys.argv[2]) != 0 and first != [sys.argv[4]]
print(f"hil_e2e_test: servo wake-up p99 {w['p99_us']:.0f} us max {w['max_us']:.0f} us, cycle max {c['max_us']:.0f} us "
      f"(the hold: {sys.argv[3]} us), exit {sys.argv[2]}, first event out of ACTIVE {first}")
# a deadline fault is timing alone: the daemon's work is ~0.2 ms of the 0.9 ms budget, so five
# misses in a row are the machine taking its core, whatever the wake-up statistics say
stalled = (w["p99_us"] > 1000 or w["max_us"] > float(sys.argv[3]) or c["max_us"] > 1000
           or first == ["deadline_miss"])
sys.exit(0 if faulted and stalled else 1)
PY
    }
    "$here/scripts/hil.sh" --build "$build" --out "$out" --duration 5 --clock realtime --quiet \
      --sim-arg=--stall --sim-arg=4:8
    rc=$?
    [[ -s "$out/servod.json" && -s "$out/sim.json" ]] || { tail -n 20 "$out/servod.log" "$out/sim.log"; fail "no summaries (exit $rc)"; }
    judge_machine "$out" "$rc"
    "$py" -c "import json; s=json.load(open('$out/servod.json')); m=json.load(open('$out/sim.json')); print('hil_e2e_test: bus thread on: exit $rc, events', s['events'], 'held', s['held_inputs'], 'stale answers', m['stale_answers'], 'bus thread', m['bus_thread'])"
    [[ $rc -eq 0 ]] || fail "the daemon did not ride through an 8 ms plant stall (exit $rc)"
    check_json 'sim["stalls"] == 1 and sim["bus_thread"]["enabled"]'
    check_json 'sim["stale_answers"] >= 5'   # the stall was answered, from the last state
    check_json 'set(s["events"]) <= {"bring_up_complete", "enable_command", "stop_request", "damping_done"}'
    check_json 's["held_inputs"]["max_in_row"] <= s["held_inputs"]["limit"]'
    check_json 'not h["fell_while_active"]'
    off="$out/bus_thread_off"
    "$here/scripts/hil.sh" --build "$build" --out "$off" --duration 5 --clock realtime --quiet \
      --sim-arg=--stall --sim-arg=4:8 --sim-arg=--bus-thread --sim-arg=off
    rc=$?
    [[ -s "$off/servod.json" ]] || { tail -n 20 "$off/servod.log" "$off/sim.log"; fail "no summary without the bus thread (exit $rc)"; }
    judge_machine "$off" "$rc" input_missing
    "$py" -c "import json; s=json.load(open('$off/servod.json')); print('hil_e2e_test: bus thread off: exit $rc, events', s['events'], 'held', s['held_inputs'])"
    [[ $rc -eq 3 ]] || fail "without the bus thread the stall should have stopped the daemon in FAULT (exit 3), got $rc"
    "$py" - "$off" <<'PY' || fail "without the bus thread the first fault should be input_missing"
import json, os, sys
s = json.load(open(os.path.join(sys.argv[1], "servod.json")))
first = [e for e in s["event_log"] if e["from"] == "active"]
print("hil_e2e_test: first event out of ACTIVE:", first[0]["reason"] if first else None, first[0]["detail"] if first else "")
sys.exit(0 if first and first[0]["reason"] == "input_missing" else 1)
PY
    ;;
  fault)
    spec=$1 reason=$2 stop=$3
    # the deadline policy relaxed: this run checks the reaction to the injected fault, and a
    # machine stall before it (seen: 5 cycles of 1.3-7.4 ms of thread CPU time in a row, in the
    # 0.2 s before the fault, on a loaded 2-core VM) would stop the daemon for its timing first
    "$here/scripts/hil.sh" --build "$build" --out "$out" --duration 5 --quiet --fault "2.0:$spec" \
      --servod-arg --config --servod-arg "$(relaxed_deadline_config)"
    rc=$?
    [[ $rc -eq 3 ]] || { tail -n 20 "$out/servod.log" "$out/sim.log"; fail "expected the daemon to stop in FAULT (exit 3), got $rc"; }
    [[ -s "$out/sim.json" ]] || fail "hyq-sim wrote no summary (did it crash?)"
    grep -q "Segmentation\|Aborted\|terminate called" "$out/servod.log" "$out/sim.log" && fail "a process crashed"
    "$py" -c "import json; [print('hil_e2e_test: event', e['cycle'], e['time_s'], e['from'], '->', e['to'], e['reason'], e['stop'], e['detail']) for e in json.load(open('$out/servod.json'))['event_log'][:8]]"
    # the first fault in ACTIVE: its reason, its stop class (docs/servo.md, "Graded stops") and
    # how long after the fault it came (the daemon's lock-step time and hyq-sim's simulated time
    # both count SYNC periods from 0)
    first="[e for e in s['event_log'] if e['from'] == 'active' and e['stop'] != 'none'][0]"
    check_json "$first['reason'] == '$reason'"
    check_json "$first['stop'] == '$stop'"
    # within 2 cycles of the fault reaching the daemon (one period of transport); a missing
    # answer is first held for timing.max_held_cycles cycles (config/hyq_hal.yaml, docs/hal.md)
    held=0; [[ "$reason" == input_missing ]] && held=$(sed -n 's/^  max_held_cycles: *\([0-9]*\).*/\1/p' "$here/config/hyq_hal.yaml")
    check_json "0.0 <= $first['time_s'] - 2.0 <= 0.0031 + 0.001 * $held"
    if [[ "$stop" == cut ]]; then
      # category 0: damping at once
      check_json "$first['to'] == 'damping'"
    else
      # category 1: the sit-down in ACTIVE, then its damping; the trunk down gently and upright
      check_json "$first['to'] == 'active'"
      check_json "any(e['from'] == 'active' and e['to'] == 'damping' and e['stop'] == '$stop' for e in s['event_log'])"
      check_json 'sim["sat_down"] and not sim["fell"]'
    fi
    check_json 'sim["contact_speed_m_s"] <= 0.5'
    check_json 's["final_mode"] == "stopped"'
    decode_log
    grep -q "$reason" "$out/csv/HYQ_EVENT.csv" || fail "the event $reason is not in the LCM log"
    ;;
  sigterm)
    # the deadline policy relaxed, as for the faults: this run checks the stop on SIGTERM
    "$here/scripts/hil.sh" --build "$build" --out "$out" --duration 0 --sigterm-after 2 --quiet \
      --servod-arg --config --servod-arg "$(relaxed_deadline_config)"
    rc=$?
    [[ $rc -eq 0 ]] || { tail -n 20 "$out/servod.log"; fail "hil.sh exit $rc after SIGTERM"; }
    grep -q "Terminated: controlled stop" "$out/servod.log" || true
    check_json 's["final_mode"] == "stopped"'
    # the stop sits the robot down to the crouch first (an event without a mode
    # change), then damps, then 0 N·m; hyq-sim sees it sit down, slowly, not fall
    check_json "[e for e in s['event_log'] if e['from'] == 'active'][0]['detail'] == 'sitting down to the crouch first'"
    check_json "[e for e in s['event_log'] if e['from'] == 'active' and e['to'] != 'active'][0]['reason'] == 'stop_request'"
    check_json "[e for e in s['event_log'] if e['from'] == 'active' and e['to'] != 'active'][0]['to'] == 'damping'"
    check_json "s['event_log'][-1]['to'] == 'stopped'"
    check_json 'not sim["fell"] and sim["sat_down"] and sim["contact_speed_m_s"] <= 0.5'
    decode_log
    ;;
  commands)
    cmd="$build/tools/hyq-command/hyq-command"
    "$cmd" --generate-key "$out/robot.key" >/dev/null || fail "hyq-command --generate-key"
    "$cmd" --generate-key "$out/other.key" >/dev/null || fail "hyq-command --generate-key"
    servo_config "$out/servo.yaml" "$here/config/hyq_hal.yaml" -e "s|^  auto_enable: .*|  auto_enable: false|"
    # the deadline policy relaxed, as for the faults: this run checks the command channel
    relax_deadline "$out/servo.yaml"
    cat > "$out/commands.sh" <<EOS
$netns_script_head
"$build/tools/hyq-sim/hyq-sim" --mode lockstep --mu 0.1 --summary "$out/sim.json" --quiet 2>"$out/sim.log" &
sim=\$!
sleep 0.2
"$build/tools/hyq-servod/hyq-servod" --config "$out/servo.yaml" --clock lockstep \
  --reference trot --controller two_stage --mu 0.1 --duration 0 --commands \
  --command-key "$out/robot.key" --summary "$out/servod.json" 2>"$out/servod.log" &
servod=\$!
# wait for STANDBY (its once-a-second progress line), not for a guessed time
for i in \$(seq 300); do grep -q "^hyq-servod: standby" "$out/servod.log" && break; sleep 0.1; done
"$cmd" --key "$out/other.key" enable    # another robot's key
sleep 0.3
"$cmd" --key "$out/robot.key" --sender op@hil enable
sleep 1.5
"$cmd" --key "$out/robot.key" --sender op@hil damp
sleep 1.5
kill -TERM \$servod; wait \$servod; rc=\$?
kill -TERM \$sim; wait \$sim
exit \$rc
EOS
    chmod +x "$out/commands.sh"
    unshare -n "$out/commands.sh" || { tail -n 20 "$out/servod.log"; fail "the command run failed"; }
    check_json "s['command_channel']['unauthenticated'] == 1"
    check_json "s['command_channel']['accepted'] == 2"
    check_json "[e['reason'] for e in s['event_log'] if e['from'] == 'standby' and e['to'] == 'active'] == ['enable_command']"
    check_json "[e['reason'] for e in s['event_log'] if e['from'] == 'active'][0] == 'damping_command'"
    check_json "s['active_s'] > 0.3 and not [e for e in s['event_log'] if e['reason'] == 'command_rejected']"
    ;;
  recover)
    # lock-step, the command channel on, auto-enable, the trot with the two-stage ID; lf_kfe's
    # board silent for 0.5 s at 4 s of simulated time: the degraded sit-down, then FAULT. Once
    # the board is back, an acknowledgement (hyq-command ack) and an enable: the robot stands up
    # and trots again in the same daemon, 3 s of reference, then the controlled stop; no fall
    cmd="$build/tools/hyq-command/hyq-command"
    "$cmd" --generate-key "$out/robot.key" >/dev/null || fail "hyq-command --generate-key"
    servo_config "$out/servo.yaml" "$here/config/hyq_hal.yaml"
    relax_deadline "$out/servo.yaml"
    cat > "$out/recover.sh" <<EOS
$netns_script_head
"$build/tools/hyq-sim/hyq-sim" --mode lockstep --mu 0.1 --fault 4.0:silent:lf_kfe:0.5 --summary "$out/sim.json" --truth "$out/truth.csv" --quiet 2>"$out/sim.log" &
sim=\$!
sleep 0.2
"$build/tools/hyq-servod/hyq-servod" --config "$out/servo.yaml" --clock lockstep --auto-enable \
  --reference trot --controller two_stage --mu 0.1 --duration 3 --commands \
  --command-key "$out/robot.key" --summary "$out/servod.json" 2>"$out/servod.log" &
servod=\$!
${sim_clock_functions//TRUTH_CSV/$out/truth.csv}
# the sit-down's damping holds until the robot rests (at most 5 s after it): acknowledgements
# every second of simulated time from 7 s to 14 s (one in DAMPING is refused, an event), then the enable
for t in 7 8 9 10 11 12 13 14; do
  wait_sim \$t || { echo "recover: the simulation did not reach \$t s" >&2; kill -TERM \$servod \$sim; exit 1; }
  "$cmd" --key "$out/robot.key" --sender op@hil ack
done
wait_sim 14.5 || { echo "recover: the simulation did not reach 14.5 s" >&2; kill -TERM \$servod \$sim; exit 1; }
# the channel takes commands at most commands.max_rate_hz (20 Hz) apart in wall time, and half a
# second of a resting robot's lock-step can take less than 50 ms: the enable waits out the limit.
# In lock-step the loopback's UDP receive buffers overflow now and then (thousands of
# RcvbufErrors a run: the buses' frames and the telemetry at many times real time), and a
# command datagram can be lost with them: the enable is sent three times, 0.3 s apart (one taken
# in STANDBY, the others refused in ACTIVE)
for k in 1 2 3; do
  sleep 0.3
  "$cmd" --key "$out/robot.key" --sender op@hil enable
done
# the second ACTIVE ends with the run's duration; a daemon left in FAULT would never end
for i in \$(seq 1200); do kill -0 \$servod 2>/dev/null || break; sleep 0.1; done
kill -0 \$servod 2>/dev/null && { echo "recover: the daemon did not finish (left in FAULT?)" >&2; kill -TERM \$servod; }
wait \$servod; rc=\$?
kill -TERM \$sim; wait \$sim
exit \$rc
EOS
    chmod +x "$out/recover.sh"
    unshare -n "$out/recover.sh" || { tail -n 20 "$out/servod.log" "$out/sim.log"; "$py" -c "import json; print('hil_e2e_test: command channel', json.load(open('$out/servod.json'))['command_channel'])"; fail "the recovery run failed"; }
    "$py" -c "import json; [print('hil_e2e_test: event', e['cycle'], e['time_s'], e['from'], '->', e['to'], e['reason'], e['stop'], e['detail']) for e in json.load(open('$out/servod.json'))['event_log']]"
    # the fault's degraded sit-down into FAULT, the acknowledgement, the second enable, the stop
    check_json "[e['reason'] for e in s['event_log'] if e['stop'] == 'degraded'][:1] == ['input_missing']"
    check_json "any(e['from'] == 'fault' and e['to'] == 'standby' and e['reason'] == 'acknowledge' for e in s['event_log'])"
    check_json "[e['to'] for e in s['event_log'] if e['reason'] == 'enable_command' and e['from'] == 'standby'] == ['active', 'active']"
    check_json "s['final_mode'] == 'stopped'"
    # ACTIVE again for the stand-up and 3 s of trot (the first ACTIVE: about 4 s)
    check_json "s['active_s'] >= 4.0 + 2.0 + 3.0"
    # standing and upright while it trots again (hyq-sim's truth: base height and tilt from the
    # end of the second stand-up to the stop; how the fault's sit-down itself ended is the fault
    # matrix's to judge)
    "$py" - "$out" <<'PY' || fail "the robot did not stand and trot upright after the recovery"
import csv, json, math, os, sys
out = sys.argv[1]
ev = json.load(open(os.path.join(out, "servod.json")))["event_log"]
t_on = [e["time_s"] for e in ev if e["reason"] == "enable_command" and e["to"] == "active"][1] + 2.5
t_off = [e["time_s"] for e in ev if e["reason"] == "stop_request"][0]
z, tilt = [], []
for r in csv.DictReader(open(os.path.join(out, "truth.csv"))):
    if t_on <= float(r["t"]) <= t_off:
        w, x, y = float(r["qw"]), float(r["qx"]), float(r["qy"])
        z.append(float(r["z"]))
        tilt.append(math.degrees(math.acos(max(-1.0, min(1.0, 1 - 2 * (x * x + y * y))))))
ok = len(z) > 100 and min(z) >= 0.5 and max(tilt) <= 10.0  # truth rows every 10 ms
print(f"hil_e2e_test: {'ok  ' if ok else 'FAIL'} trotting again {t_on:.2f}-{t_off:.2f} s: base height "
      f"{min(z):.3f}-{max(z):.3f} m (>= 0.5), tilt at most {max(tilt):.1f} deg (<= 10)")
sys.exit(0 if ok else 1)
PY
    ;;
  steer)
    cmd="$build/tools/hyq-command/hyq-command"
    "$cmd" --generate-key "$out/robot.key" >/dev/null || fail "hyq-command --generate-key"
    servo_config "$out/servo.yaml" "$here/config/hyq_hal.yaml"
    # the deadline policy relaxed, as for the faults: this run checks where the robot goes
    relax_deadline "$out/servo.yaml"
    cat > "$out/steer.sh" <<EOS
$netns_script_head
"$build/tools/hyq-sim/hyq-sim" --mode lockstep --mu 0.8 --summary "$out/sim.json" --truth "$out/truth.csv" --quiet 2>"$out/sim.log" &
sim=\$!
sleep 0.2
"$build/tools/hyq-servod/hyq-servod" --config "$out/servo.yaml" --clock lockstep --auto-enable \
  --reference trot --controller two_stage --mu 0.8 --duration 10 --commands \
  --command-key "$out/robot.key" --summary "$out/servod.json" 2>"$out/servod.log" &
servod=\$!
${sim_clock_functions//TRUTH_CSV/$out/truth.csv}
wait_sim 3 || { echo "steer: the simulation did not reach 3 s" >&2; kill -TERM \$servod \$sim; exit 1; }
"$cmd" --key "$out/robot.key" --sender op@hil velocity 0.3 0 0
wait_sim 6 || { echo "steer: the simulation did not reach 6 s" >&2; kill -TERM \$servod \$sim; exit 1; }
"$cmd" --key "$out/robot.key" --sender op@hil velocity 0.2 0 0.4
wait \$servod; rc=\$?
kill -TERM \$sim; wait \$sim
exit \$rc
EOS
    chmod +x "$out/steer.sh"
    start=$SECONDS
    unshare -n "$out/steer.sh" || { tail -n 20 "$out/servod.log" "$out/sim.log"; fail "the steered run failed"; }
    echo "hil_e2e_test: steered run took $((SECONDS - start)) s wall"
    check_json "s['final_mode'] == 'stopped' and s['active_s'] >= 9.99"
    check_json "s['command_channel']['accepted'] == 2"
    check_json "len([e for e in s['event_log'] if e['reason'] == 'command_applied' and e['detail'].startswith('velocity = ')]) == 2"
    # no fault while ACTIVE (on mu = 0.8 the sit-down after the stop can fold a knee past its
    # range + margin during the damping: an out_of_range event then, after the run judged here)
    check_json "[e['reason'] for e in s['event_log'] if e['from'] == 'active' and e['to'] != 'active'] == ['stop_request']"
    check_json "not [e for e in s['event_log'] if e['from'] == 'active' and e['reason'] not in ('command_applied', 'stop_request')]"
    check_json 'not sim["fell"] or sim["fell_at_s"] > sim["released_at_s"] + s["active_s"]'
    "$py" "$here/tests/hil/steered_run.py" "$out" --plot "$out/steered_run.png" \
      || fail "the robot did not go where it was steered"
    ;;
  kill9)
    # the deadline policy relaxed: this run checks the boards' reaction, not the daemon's timing
    # on a shared 2-core machine (a daemon that stopped on its own would leave nothing to test)
    # and the late-answer tolerances too (hyq-sim steps on SCHED_OTHER beside it)
    sed -e 's|^  max_held_cycles: .*|  max_held_cycles: 200|' "$here/config/hyq_hal.yaml" > "$out/rt_hal.yaml"
    servo_config "$out/rt_servo.yaml" "$out/rt_hal.yaml"
    relax_deadline "$out/rt_servo.yaml"
    cat > "$out/kill9.sh" <<EOS
$netns_script_head
# the plant steps on its own clock: SCHED_FIFO below the servo thread (80), as hyq-sim's stepping
# thread runs in real time, so that a busy machine (the suite beside two CPU hogs) does not
# starve it (plain when chrt fails)
rt=(chrt -f 70); chrt -f 70 true 2>/dev/null || rt=()
"\${rt[@]}" "$build/tools/hyq-sim/hyq-sim" --mode realtime --mu 0.1 --summary "$out/sim.json" --truth "$out/truth.csv" --quiet 2>"$out/sim.log" &
sim=\$!
sleep 0.3
"$build/tools/hyq-servod/hyq-servod" --config "$out/rt_servo.yaml" --clock realtime --auto-enable \
  --reference trot --controller two_stage --mu 0.1 --duration 0 --no-telemetry 2>"$out/servod.log" &
servod=\$!
sleep 4
kill -KILL \$servod || { echo "kill9: the daemon had exited before the kill" >&2; tail -n 5 "$out/servod.log" >&2; kill -TERM \$sim; exit 1; }
wait \$servod 2>/dev/null
sleep 0.5
kill -TERM \$sim; wait \$sim
EOS
    chmod +x "$out/kill9.sh"
    unshare -n "$out/kill9.sh" || fail "the kill -9 run failed"
    echo '{}' > "$out/servod.json"
    grep -E "^hyq-servod: .*(ACTIVE|active)" "$out/servod.log" | head -2 || true
    check_json "sim['boards_tripped'] == 12"
    check_json "sim['max_trip_delay_ms'] <= 10.0"
    check_json "sim['max_abs_setpoint_Nm'] == 0.0"
    # the robot was under torque before the kill (truth.csv: time, base q 7, q 12, v 12, tau 12)
    "$py" - "$out/truth.csv" <<'PY' || fail "no torque was applied before the kill"
import csv, sys
rows = [list(map(float, r)) for r in csv.reader(open(sys.argv[1])) if r and r[0][0].isdigit()]
peak = max(max(abs(x) for x in r[32:44]) for r in rows)
last = max(abs(x) for x in rows[-1][32:44])
print(f"hil_e2e_test: peak |tau| applied {peak:.1f} N m, at the end {last:.1f} N m")
sys.exit(0 if peak > 10.0 and last < 1e-9 else 1)
PY
    ;;
  vcan)
    vm="$here/../shared/tools/run-in-vcan-vm"
    script="$out/in_vm.sh"
    # software-emulated CPU (TCG): a cycle takes milliseconds, so this run checks the SocketCAN
    # path, not timing: generous lock-step waits, the deadline policy off, the PID controller
    servo_config "$out/vm_servo.yaml" "$here/config/hyq_hal.yaml" \
        -e 's|^  clock: lockstep .*|  clock: lockstep\n  lockstep_timeout_s: 5\n  lockstep_short_timeout_s: 1\n  lockstep_bringup_timeout_s: 600|' \
        -e 's|^  kind: two_stage$|  kind: pid|'
    relax_deadline "$out/vm_servo.yaml"
    cat > "$script" <<EOS
#!/bin/sh
set -u
if ! ip link show vcan0 >/dev/null 2>&1; then
  for i in 0 1 2 3; do ip link add dev vcan\$i type vcan && ip link set vcan\$i mtu 72 up; done
fi
IF="--interface lf=socketcan-fd:vcan0 --interface rf=socketcan-fd:vcan1 --interface lh=socketcan-fd:vcan2 --interface rh=socketcan-fd:vcan3"
"$build/tools/hyq-sim/hyq-sim" \$IF --mode lockstep --summary "$out/sim.json" --quiet 2>"$out/sim.log" &
sim=\$!
sleep 0.5
"$build/tools/hyq-servod/hyq-servod" --config "$out/vm_servo.yaml" \$IF \
  --reference stand --duration 0.3 --no-telemetry --exit-on-fault --quiet \
  --summary "$out/servod.json" 2>"$out/servod.log"
rc=\$?
kill -TERM \$sim; wait \$sim
exit \$rc
EOS
    chmod +x "$script"
    if unshare -n sh -c 'ip link add dev hyqprobe type vcan' >/dev/null 2>&1; then
      echo "hil_e2e_test: native vcan (kernel $(uname -r)), in a private network namespace"
      unshare -n "$script"
      rc=$?
    else
      [[ -x "$vm" ]] || { echo "hil_e2e_test: SKIP: no vcan in this kernel and no $vm"; exit 77; }
      command -v qemu-system-x86_64 >/dev/null || { echo "hil_e2e_test: SKIP: no vcan in this kernel and qemu-system-x86_64 missing"; exit 77; }
      echo "hil_e2e_test: this kernel ($(uname -r)) has no vcan: running inside $vm"
      "$vm" -W -w "$out" -c 2 -m 1024 -t 900 -- "$script"
      rc=$?
    fi
    [[ $rc -eq 0 ]] || { tail -n 20 "$out/servod.log" "$out/sim.log" 2>/dev/null; fail "daemon exit $rc over vcan"; }
    echo '{}' > "$out/hil.json"
    check_json 's["final_mode"] == "stopped" and s["active_s"] >= 0.299'
    check_json 'set(s["events"]) <= {"bring_up_complete", "enable_command", "stop_request"}'
    check_json 'sim["lockstep_forced_steps"] == 0'
    # standing while ACTIVE (it sits down during the controlled stop's damping afterwards)
    check_json 'not sim["fell"] or sim["fell_at_s"] > sim["released_at_s"] + s["active_s"]'
    ;;
  mainjob)
    # (hil.sh empties its output folder: the command's own output goes beside it)
    main_job() { (cd "$here" && HYQ_PRESET="${HYQ_PRESET:-ci}" scripts/run.sh --duration 1 --out "$out" --quiet "$@") > "$out.run.log" 2>&1; }
    with_stall_retries 1 main_job
    cat "$out.run.log"
    [[ $rc -eq 0 ]] || fail "scripts/run.sh exit $rc"
    grep -q "did not fall while active" "$out.run.log" || fail "no summary line about the robot"
    grep -q "tracking error" "$out.run.log" || fail "no tracking-error line in the summary"
    [[ -s "$out/telemetry.lcmlog" ]] || fail "no LCM log kept"
    ;;
  compare)
    # the realistic profile whole (docs/simulation.md: hydraulics, 1 cycle of delay, payload,
    # link errors and biases of seed 1, joint friction); the daemon keeps the nominal model
    declare -A err
    cfg=$(relaxed_deadline_config)
    sed '0,/^controller:$/s//controller:\n  disturbance_observer:\n    enabled: true/' "$cfg" > "$out/dob_servo.yaml"
    grep -A1 "^  disturbance_observer:$" "$out/dob_servo.yaml" | grep -q "^    enabled: true$" || fail "could not switch the disturbance observer on in $out/dob_servo.yaml"
    for c in pid two_stage two_stage+dob; do
      c_cfg=$cfg; [[ $c == *+dob ]] && c_cfg=$out/dob_servo.yaml
      # a bring-up that found a bus's boards silent (the run before still releasing its ports:
      # seen once in CI, "no boot-up after NMT reset" on one bus) is the rig's, not the
      # controller's: run again once, saying so
      for attempt in 1 2; do
        "$here/scripts/hil.sh" --build "$build" --out "$out/$c" --duration 5 --controller "${c%+dob}" --quiet \
          --no-logger --sim-arg --profile --sim-arg realistic \
          --sim-arg --link-errors --sim-arg 1 --sim-arg --bias-seed --sim-arg 1 \
          --servod-arg --config --servod-arg "$c_cfg"
        rc=$?
        grep -q "bring-up failed" "$out/$c/servod.log" 2>/dev/null && ((attempt == 1)) || break
        echo "hil_e2e_test: $c: the bring-up failed ($(grep -m1 'bring-up failed' "$out/$c/servod.log")); running it again"
        sleep 1
      done
      [[ $rc -eq 0 ]] || { tail -n 20 "$out/$c/servod.log"; fail "$c: hil.sh exit $rc (a fault or a fall on the realistic plant)"; }
      err[$c]=$("$py" -c "import json; print(json.load(open('$out/$c/servod.json'))['tracking_error_mean_rad'])")
    done
    echo "hil_e2e_test: realistic plant, trot mu 0.1: PID ${err[pid]} rad, two-stage ID ${err[two_stage]} rad, two-stage ID + disturbance observer ${err[two_stage+dob]} rad"
    for c in two_stage two_stage+dob; do
      "$py" -c "import sys; p, t = ${err[pid]}, ${err[$c]}; print(f'hil_e2e_test: $c vs PID {100 * (t - p) / p:+.1f} %'); sys.exit(0 if t < p else 1)" \
        || fail "$c tracked no better than the PID on the realistic plant"
    done
    ;;
  *) fail "unknown mode $mode" ;;
esac
echo "hil_e2e_test: PASS ($mode)"
