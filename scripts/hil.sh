#!/usr/bin/env bash
# Hardware-in-the-loop run: hyq-sim (MuJoCo HyQ behind its boards) and hyq-servod (the daemon,
# unmodified) on four virtual CAN buses, with lcm-logger recording the telemetry, in a private
# network namespace so that nothing leaves the machine. Prints a summary; keeps everything in OUT.
#
#   scripts/hil.sh [--out DIR] [--duration S] [--reference trot|figure_eight|stand]
#                  [--controller two_stage|stage1|noslip|pid|pd_gravity] [--mu MU] [--clock lockstep|realtime]
#                  [--fault T:KIND:TARGET[:ARG]]... [--sim-arg ARG]... [--servod-arg ARG]...
#                  [--build DIR] [--config FILE] [--no-logger] [--candump] [--bus-trace] [--sigterm-after S] [--quiet]
#                  [--transport shm|udp]
#
# --transport: the virtual CAN buses between hyq-sim and the daemon. shm (the default in
#   lock-step): shared memory, a doorbell per hand-off instead of a datagram per frame
#   (drivers/shm_channel.h); udp (the default with --clock realtime, whose runs measure timing
#   with kernel I/O per cycle as on the robot's SocketCAN): python-can's udp_multicast on
#   loopback, which --candump, --bus-trace and python-can tools need (they choose it).
# --config FILE: the daemon's configuration (default config/hyq_servo_sim.yaml), e.g. a copy with
#   other estimator or gain settings.
# --bus-trace: hyq-candump records each bus (OUT/bus_<name>.log, candump format, kernel receive
#   timestamps), then scripts/bus_trace_report.py times the boards' answers (OUT/bus_trace.txt):
#   what to look at when a real-time run stops on input_missing.
# --servod-bin PATH: another hyq-servod (e.g. a thread-sanitizer build) against this build's hyq-sim.
# --sigterm-after S: SIGTERM to the daemon after S wall seconds (with --duration 0: run until then).
# Defaults: 5 s of trot on mu = 0.1 with the two-stage ID, lock-step, OUT = hil-run/.
# The last line is the estimator's accuracy against the truth (scripts/estimator_accuracy.py
#   --summary, its numbers in OUT/estimator_accuracy.json): lock-step runs with the logger only.
# Exit status: the daemon's (0 controlled stop, 3 stopped in FAULT), 4 when the robot fell.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"

out=hil-run duration=5 reference=trot controller=two_stage mu=0.1 clock=lockstep
build="$here/build/ci" config="$here/config/hyq_servo_sim.yaml" logger=1 candump=0 bus_trace=0 quiet=0 sigterm_after= servod_bin=
transport=
faults=() sim_args=() servod_args=()
usage() { sed -n '2,25p' "$0" | sed 's/^# \{0,1\}//'; exit "${1:-0}"; }
while (($#)); do
  case "$1" in
    --out) out="$2"; shift ;;
    --duration) duration="$2"; shift ;;
    --reference) reference="$2"; shift ;;
    --controller) controller="$2"; shift ;;
    --mu) mu="$2"; shift ;;
    --clock) clock="$2"; shift ;;
    --fault) faults+=(--fault "$2"); shift ;;
    --sim-arg) sim_args+=("$2"); shift ;;
    --sim-arg=*) sim_args+=("${1#--sim-arg=}") ;;
    --servod-arg) servod_args+=("$2"); shift ;;
    --servod-arg=*) servod_args+=("${1#--servod-arg=}") ;;
    --build) build="$2"; shift ;;
    --config) config="$(cd "$(dirname "$2")" && pwd)/$(basename "$2")"; shift ;;
    --no-logger) logger=0 ;;
    --sigterm-after) sigterm_after="$2"; shift ;;
    --servod-bin) servod_bin="$2"; shift ;;
    --candump) candump=1 ;;
    --bus-trace) bus_trace=1 ;;
    --quiet) quiet=1 ;;
    --transport) transport="$2"; shift ;;
    -h|--help) usage 0 ;;
    *) echo "hil.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done
[[ "$out" = /* ]] || out="$PWD/$out"
[[ -n "$transport" ]] || { [[ "$clock" == realtime ]] && transport=udp || transport=shm; }
case "$transport" in
  shm|udp) ;;
  *) echo "hil.sh: --transport: expected shm or udp, found '$transport'" >&2; exit 2 ;;
esac
# the recorders listen on the UDP buses
((candump || bus_trace)) && transport=udp

# a private network namespace (root: unshare -n; otherwise a user namespace too)
if [[ -z "${HYQ_HIL_NETNS:-}" ]]; then
  ns=(unshare -n)
  ((EUID == 0)) || ns=(unshare -rn)
  exec "${ns[@]}" env HYQ_HIL_NETNS=1 "$0" --out "$out" --duration "$duration" \
    --reference "$reference" --controller "$controller" --mu "$mu" --clock "$clock" \
    --build "$build" --config "$config" --transport "$transport" "${faults[@]}" $( ((logger)) || echo --no-logger) \
    ${sigterm_after:+--sigterm-after "$sigterm_after"} ${servod_bin:+--servod-bin "$servod_bin"} \
    $( ((candump)) && echo --candump) $( ((bus_trace)) && echo --bus-trace) $( ((quiet)) && echo --quiet) \
    "${sim_args[@]/#/--sim-arg=}" "${servod_args[@]/#/--servod-arg=}"
fi
ip link set lo up
ip route add 224.0.0.0/4 dev lo 2>/dev/null || true
# keep hyq-sim's default bus ports out of this namespace's ephemeral ports (LCM's and the
# channels' senders draw from them; one that drew a bus port blocked that bus's receiver)
sysctl -qw net.ipv4.ip_local_reserved_ports=43101-43104 2>/dev/null || true

sim="$build/tools/hyq-sim/hyq-sim"
servod="${servod_bin:-$build/tools/hyq-servod/hyq-servod}"
for b in "$sim" "$servod"; do
  [[ -x "$b" ]] || { echo "hil.sh: $b not built (scripts/run.sh builds it, or cmake --build --preset ci)" >&2; exit 1; }
done
mkdir -p "$out"
rm -f "$out"/*.json "$out"/*.csv "$out"/telemetry.lcmlog "$out"/*.log "$out"/bus_trace.txt
url='udpm://239.255.76.67:7667?ttl=0'
pids=()
cleanup() { for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT

if ((logger)); then
  # a 4 MiB socket buffer (capped by net.core.rmem_max) for the bursts of a lock-step run; LCM is
  # best effort and lcm-logger can still lose datagrams when busy (measured 8-14 % of the state
  # messages at 4x real time): the daemon repeats every event (docs/telemetry.md)
  lcm-logger --lcm-url="$url&recv_buf_size=4194304" --quiet "$out/telemetry.lcmlog" >"$out/lcm-logger.log" 2>&1 &
  pids+=($!)
fi
if ((candump)); then
  /usr/bin/python3 "$here/tests/hil/python_can_logger.py" "$out/candump" >"$out/python-can.log" 2>&1 &
  pids+=($!)
fi
trace_pids=()
if ((bus_trace)); then
  # hyq-sim's default buses (docs/simulation.md); an 8 MiB socket buffer (capped by rmem_max)
  # so that a recorder the scheduler left waiting loses nothing: the times are the kernel's
  port=43101
  for b in lf rf lh rh; do
    "$build/tools/hyq-candump/hyq-candump" -L "$b" -o "$out/bus_$b.log" "udp::$port,rcvbuf=8388608" \
      2>"$out/bus_$b.err" &
    trace_pids+=($!)
    port=$((port + 1))
  done
  pids+=("${trace_pids[@]}")
  # each recorder says "recording" once its socket has joined the bus: wait for all four (a
  # loaded machine can take longer to start one than hyq-sim and the daemon take to begin)
  for ((i = 0; i < 100; i++)); do
    n=0
    for b in lf rf lh rh; do grep -q "recording" "$out/bus_$b.err" 2>/dev/null && n=$((n + 1)); done
    ((n == 4)) && break
    sleep 0.05
  done
  ((n == 4)) || echo "hil.sh: --bus-trace: a recorder has not started after 5 s (see $out/bus_*.err)" >&2
fi
# the buses: hyq-sim's default UDP ones (the configuration's), or a shared-memory group of this
# run's own (the devices' side is hyq-sim's; it removes the segment when it ends)
sim_bus=() servod_bus=()
if [[ "$transport" == shm ]]; then
  shm_group="hil-$$-$RANDOM"
  for b in lf rf lh rh; do
    sim_bus+=(--interface "$b=shm:$shm_group:$b,side=devices")
    servod_bus+=(--interface "$b=shm:$shm_group:$b")
  done
  trap 'cleanup; rm -f /dev/shm/hyq-can."$shm_group"*' EXIT
fi
"$sim" --mode "$clock" --mu "$mu" --summary "$out/sim.json" --truth "$out/truth.csv" --quiet \
  "${sim_bus[@]}" "${faults[@]}" "${sim_args[@]}" 2>"$out/sim.log" &
sim_pid=$!
sleep 0.2
((quiet)) && q=(--quiet) || q=()
set +e
"$servod" --config "$config" --clock "$clock" --auto-enable --reference "$reference" --controller "$controller" \
  --mu "$mu" --duration "$duration" --exit-on-fault --summary "$out/servod.json" \
  --lcm-url "$url" "${servod_bus[@]}" "${q[@]}" "${servod_args[@]}" 2>"$out/servod.log" &
servod_pid=$!
if [[ -n "$sigterm_after" ]]; then  # the operator's Ctrl-C / systemctl stop
  sleep "$sigterm_after"
  kill -TERM "$servod_pid" 2>/dev/null || true
fi
wait "$servod_pid"
servod_rc=$?
set -e
kill -TERM "$sim_pid" 2>/dev/null || true
wait "$sim_pid" 2>/dev/null || true
sleep 0.2
cleanup
trap - EXIT
[[ -n "${shm_group:-}" ]] && rm -f /dev/shm/hyq-can."$shm_group"*
if ((bus_trace)); then
  /usr/bin/python3 "$here/scripts/bus_trace_report.py" "$out" >"$out/bus_trace.txt" 2>&1 ||
    echo "hil.sh: bus_trace_report.py failed: see $out/bus_trace.txt" >&2
fi

set +e
HYQ_HIL_SCRIPTS="$here/scripts" /usr/bin/python3 - "$out" "$servod_rc" <<'PY'
import json, sys, os
out, rc = sys.argv[1], int(sys.argv[2])
s = json.load(open(os.path.join(out, "servod.json")))
sim = json.load(open(os.path.join(out, "sim.json"))) if os.path.exists(os.path.join(out, "sim.json")) else {}
# the trot is judged while the daemon was ACTIVE: after its controlled stop (damping, then zero
# torque) the robot sits down, which is the point of the stop, not a fall
t_stop = sim.get("released_at_s", 0.0) + s["active_s"]
# any ground contact of the trunk or a leg while ACTIVE is a failure; after the stop began, a
# slow upright one is the robot sitting down (hyq-sim tells the two apart)
contact_at = sim["fell_at_s"] if sim.get("fell") else sim["sat_down_at_s"] if sim.get("sat_down") else None
fell = contact_at is not None and contact_at < t_stop - 1e-9
print(f"HIL run ({s['controller']}, {s['clock']}): {s['active_s']:.2f} s active, final mode {s['final_mode']}, daemon exit {rc}")
print(f"  tracking error   mean {s['tracking_error_mean_rad']:.4f} rad, max {s['tracking_error_max_rad']:.4f} rad")
print(f"  QP solve time    mean {s['qp_time_mean_us']:.1f} us, max {s['qp_time_max_us']:.1f} us; fallbacks {s['controller_fallbacks']} ({s.get('controller_fallbacks_deadline', 0)} on the time budget, {s.get('controller_fallbacks_deadline_stalled', 0)} of them a stalled thread)")
c, w = s["cycle_time"], s["wakeup_latency"]
print(f"  cycle time       p50 {c['p50_us']:.0f} us, p99 {c['p99_us']:.0f} us, p99.9 {c['p999_us']:.0f} us, max {c['max_us']:.0f} us")
if s["clock"] == "realtime":
    print(f"  wake-up latency  p50 {w['p50_us']:.0f} us, p99 {w['p99_us']:.0f} us, max {w['max_us']:.0f} us")
print(f"  deadline misses  {s['deadline_misses']} (max {s['max_consecutive_misses']} in a row), skipped {s['skipped_cycles']}")
hi = s.get("held_inputs", {})
if hi:
    print(f"  held inputs      {hi['total']} (longest run {hi['max_in_row']}, limit {hi['limit']}), late answers {hi['late_answers']}")
print(f"  events           {', '.join(f'{k} {v}' for k, v in s['events'].items()) or 'none'}")
if sim.get("mode") == "realtime":
    st, sl = sim.get("stepping_thread", {}), sim.get("step_lateness", {})
    print(f"  plant (real time) late steps {sim.get('late_steps')}, dropped {sim.get('dropped_steps')}, step lateness p99 "
          f"{sl.get('p99_us', 0):.0f} us, max {sl.get('max_us', 0):.0f} us; stepping thread "
          f"{'SCHED_FIFO %d' % st['priority'] if st.get('fifo') else 'SCHED_OTHER'}, "
          f"{'CPU %d' % st['cpu'] if st.get('cpu', -1) >= 0 else 'not pinned'}")
    pe = sim.get("sync_phase_error", {})
    if sim.get("sync_phase_us") is not None:
        print(f"  plant steps      {sim['sync_phase_us']:.0f} us after the SYNC, phase error p50 {pe.get('p50_us', 0):.0f} us, "
              f"p99 {pe.get('p99_us', 0):.0f} us, over {pe.get('count', 0)} of {sim.get('steps')} steps")
    else:
        print("  plant steps      free of the SYNC (--sync-phase off): the loop's delay is 1 or 2 ms by the start's chance")
if sim:
    after = ""
    if not fell and sim.get("fell"):
        after = f" (it FELL at {sim['fell_at_s']:.2f} s, after the stop began)"
    elif not fell and sim.get("sat_down"):
        after = (f" (it sat down at {sim['sat_down_at_s']:.2f} s, after the stop began, at "
                 f"{sim.get('contact_speed_m_s', 0):.2f} m/s)")
    print(f"  robot            {'FELL or sat down at %.2f s' % contact_at if fell else 'did not fall while active'}{after}; "
          f"{sim.get('simulated_time_s', 0):.2f} s simulated at {sim.get('speed', 0):.1f}x real time")
lw = sim.get("lockstep_wall") or {}
if lw:
    # hyq-sim's wait for the daemon holds the daemon's cycle and the hand-offs (the daemon's
    # cycle_time, its own work, overlaps the plant's step in part: it ends after the SYNC went out)
    print(f"  lock-step wall   {lw['per_step_us']:.1f} us per step: waiting for the daemon "
          f"{lw['waiting_for_master_us']:.1f} (its cycle {s['cycle_time']['mean_us']:.1f} mean), boards' bus "
          f"work {lw['bus_us']:.1f}, plant step {lw['plant_step_us']:.1f}, truth {lw['truth_recording_us']:.1f}")
# the trunk's pose while the reference runs (ACTIVE without its stand-up and sit-down), from the
# truth: the reference keeps the trunk level at a fixed height, so roll and pitch RMS and the
# height's s.d. are its errors, which the joint error above does not show directly
truth = os.path.join(out, "truth.csv")
t0 = sim.get("released_at_s", 0.0) + s.get("stand_up_s", 0.0)
t_ref_end = t_stop - s.get("sit_down_s", 0.0)
trunk = None
if os.path.exists(truth) and t_ref_end > t0:
    import numpy as np
    sys.path.insert(0, os.environ["HYQ_HIL_SCRIPTS"])
    from estimator_accuracy import Usage, euler_zyx, read_truth
    try:
        tr = read_truth(truth)
    except Usage as e:
        print(f"  trunk (truth)    not measured: {e}")
        tr = {"t": np.zeros(0)}
    m = (tr["t"] >= t0) & (tr["t"] <= t_ref_end)
    if m.any():
        roll, pitch, _ = euler_zyx(tr["qw"][m], tr["qx"][m], tr["qy"][m], tr["qz"][m])
        rms = lambda a: float(np.degrees(np.sqrt(np.mean(a ** 2))))
        trunk = {"roll_rms_deg": rms(roll), "pitch_rms_deg": rms(pitch),
                 "height_sd_mm": 1e3 * float(np.std(tr["z"][m])), "from_s": t0, "to_s": t_ref_end}
        print(f"  trunk (truth)    roll RMS {trunk['roll_rms_deg']:.2f} deg, pitch RMS {trunk['pitch_rms_deg']:.2f} deg, "
              f"height s.d. {trunk['height_sd_mm']:.1f} mm over the reference ({t0:.1f}-{t_ref_end:.1f} s)")
bt = os.path.join(out, "bus_trace.txt")
if os.path.exists(bt):
    first = open(bt).readline().strip()
    print(f"  bus trace        {first[len('bus trace: '):] if first.startswith('bus trace: ') else first} (bus_trace.txt)")
print(f"  files            {out}: servod.json sim.json truth.csv" + (" telemetry.lcmlog" if os.path.exists(os.path.join(out, 'telemetry.lcmlog')) else "") + (" bus_*.log" if os.path.exists(bt) else ""))
json.dump({"fell_while_active": fell, "t_stop_s": t_stop, "trunk": trunk}, open(os.path.join(out, "hil.json"), "w"))
sys.exit(4 if fell else 0)
PY
py_rc=$?
# the estimate against the truth: the two share one clock only in lock-step
if [[ "$clock" != lockstep ]]; then
  echo "  estimator        not measured: a real-time run's telemetry and truth share no clock (lock-step only)"
elif ((!logger)); then
  echo "  estimator        not measured: no telemetry log (--no-logger)"
elif [[ ! -s "$out/truth.csv" || ! -s "$out/telemetry.lcmlog" ]]; then
  echo "  estimator        not measured: $out/truth.csv or $out/telemetry.lcmlog is missing or empty"
elif line=$(/usr/bin/python3 "$here/scripts/estimator_accuracy.py" "$out" --summary \
              --json "$out/estimator_accuracy.json" 2>&1); then
  echo "  estimator        ${line#estimator: }"
else
  echo "  estimator        not measured: ${line//$'\n'/; }"
fi
((servod_rc != 0)) && exit "$servod_rc"
exit "$py_rc"
