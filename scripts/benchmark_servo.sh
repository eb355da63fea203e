#!/usr/bin/env bash
# Servo benchmarks, reproducing docs/benchmarks.md:
#   (a) real time at 1 kHz with the SHIPPED configuration (config/hyq_servo_sim.yaml and
#       config/hyq_hal.yaml, nothing relaxed): hyq-sim --mode realtime (stepping thread
#       SCHED_FIFO 70 on CPU 0, the boards' bus thread SCHED_FIFO 75 on the last CPU) +
#       hyq-servod --clock realtime (servo thread SCHED_FIFO 80 on the last CPU), DURATION s of
#       trot on mu = 0.1 with the two-stage ID, lcm-logger recording,
#       RUNS times; cyclictest beside each run for the whole of it (started with hil.sh, stopped
#       with SIGINT when it ends);
#   (b) lock-step speed: the same trot, lock-step (sim.json "speed");
#   (c) with --soak: the real-time soak (ctest hil_e2e.realtime_soak_10min, HYQ_SOAK=1), 10 minutes
#       or --soak-minutes M (on the robot's computer: 60, docs/realtime_host.md), after the host
#       check (hyq-servod --check-host, DIR/host_check.txt).
# First, 10 s of cyclictest alone on the idle machine (DIR/cyclictest_idle.txt): what the machine
# itself does. It prints, per run: active time, final mode, tracking error, deadline misses, held
# inputs, the plant's late steps, wake-up p50/p99/p99.9/max beside cyclictest's, and the per-cycle
# two-stage ID time (mean and worst over the run) beside the paper's 1 ms mean / 36 ms worst.
#
#   scripts/benchmark_servo.sh [--out DIR] [--duration S] [--runs N] [--no-lockstep] [--soak]
#                              [--soak-minutes M] [--bus-trace]
#       (defaults: DIR benchmark-servo, 60 s, 2 runs; --bus-trace: hil.sh --bus-trace on the
#       real-time runs, i.e. every bus recorded and the boards' answers timed, at some extra load)
# Writes DIR/<run>/ (hil.sh output), DIR/cyclictest_<run>.txt and DIR/summary.md.
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
out="$here/benchmark-servo" dur=60 runs=2 lockstep=1 soak=0 soak_min=10 trace=()
while (($#)); do
  case "$1" in
    --out) out="$2"; shift ;;
    --duration) dur="$2"; shift ;;
    --runs) runs="$2"; shift ;;
    --no-lockstep) lockstep=0 ;;
    --soak) soak=1 ;;
    --soak-minutes) soak=1; soak_min="$2"; shift ;;
    --bus-trace) trace=(--bus-trace) ;;
    -h|--help) sed -n '2,23p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "benchmark_servo.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done
[[ "$dur" =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "benchmark_servo.sh: --duration: expected seconds, found '$dur'" >&2; exit 2; }
[[ "$soak_min" =~ ^[1-9][0-9]*$ ]] && ((soak_min <= 120)) || { echo "benchmark_servo.sh: --soak-minutes: expected whole minutes 1..120, found '$soak_min'" >&2; exit 2; }
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || { echo "benchmark_servo.sh: --runs: expected a count >= 1, found '$runs'" >&2; exit 2; }
command -v cyclictest >/dev/null || { echo "benchmark_servo.sh: cyclictest not found (Debian: rt-tests; scripts/bootstrap.sh installs it)" >&2; exit 1; }
[[ "$out" = /* ]] || out="$PWD/$out"
mkdir -p "$out"
log="$out/commands.log"; : >"$log"
{ echo "# machine"; uname -a; nproc; grep -m1 'model name' /proc/cpuinfo
  echo "PREEMPT_RT: $(cat /sys/kernel/realtime 2>/dev/null || echo no /sys/kernel/realtime)"
  echo "kernel preempt: $(grep -o 'PREEMPT[_A-Z]*' /proc/version | head -1)"
  echo "uid $(id -u); RLIMIT_RTPRIO $(ulimit -r); RLIMIT_MEMLOCK $(ulimit -l); sched_rt_runtime_us $(cat /proc/sys/kernel/sched_rt_runtime_us)"
  echo "load before: $(cat /proc/loadavg)"; } >"$out/machine.txt"

# a real-time run with cyclictest beside it for the whole run; $1 = run name
rt_run() {
  local name="$1"
  local cmd=("$here/scripts/hil.sh" --out "$out/$name" --duration "$dur" --reference trot
             --controller two_stage --mu 0.1 --clock realtime --quiet "${trace[@]}")
  local cyc=(cyclictest -m -p 80 -i 1000 -q -h 2000)
  echo "\$ ${cyc[*]} > $out/cyclictest_$name.txt &   (SIGINT when hil.sh ends)" >>"$log"
  echo "\$ ${cmd[*]}" >>"$log"
  "${cyc[@]}" >"$out/cyclictest_$name.txt" 2>&1 &
  local cpid=$!
  echo "benchmark_servo.sh: $name: ${dur} s of real-time trot (progress: $out/$name/servod.log) ..." >&2
  "${cmd[@]}" >"$out/$name.out" 2>&1
  echo "(hil.sh exit $?)" >>"$out/$name.out"
  kill -INT "$cpid" 2>/dev/null; wait "$cpid"
  cat "$out/$name.out"
}

echo "benchmark_servo.sh: 10 s of cyclictest alone first (the machine itself) ..." >&2
echo "\$ cyclictest -m -p 80 -i 1000 -q -h 2000 -D 10 -t 2 -a > $out/cyclictest_idle.txt" >>"$log"
cyclictest -m -p 80 -i 1000 -q -h 2000 -D 10 -t 2 -a >"$out/cyclictest_idle.txt" 2>&1
echo "benchmark_servo.sh: cyclictest alone, worst wake-up per CPU (us): $(sed -n 's/^# Max Latencies: *//p' "$out/cyclictest_idle.txt")" >&2

names=()
for ((r = 1; r <= runs; ++r)); do rt_run "rt_$r"; names+=("rt_$r"); done

if ((lockstep)); then
  echo "\$ $here/scripts/hil.sh --out $out/lockstep --duration $dur --reference trot --controller two_stage --mu 0.1 --clock lockstep --quiet" >>"$log"
  echo "benchmark_servo.sh: lockstep: ${dur} s of lock-step trot ..." >&2
  "$here/scripts/hil.sh" --out "$out/lockstep" --duration "$dur" --reference trot --controller two_stage \
    --mu 0.1 --clock lockstep --quiet | tee "$out/lockstep.out"
  names+=(lockstep)
fi

/usr/bin/python3 - "$out" "$dur" "${names[@]}" <<'PY'
import json, os, re, sys
out, dur, names = sys.argv[1], float(sys.argv[2]), sys.argv[3:]
def cyc(path):
    h, ovf, mx = {}, 0, None
    for l in open(path):
        m = re.match(r"^(\d+)\s+(\d+)\s*$", l)
        if m: h[int(m[1])] = h.get(int(m[1]), 0) + int(m[2])
        if l.startswith("# Histogram Overflows"): ovf = sum(int(x) for x in l.split(":")[1].split())
        if l.startswith("# Max Latencies"): mx = max(int(x) for x in l.split(":")[1].split())
    n = sum(h.values()) + ovf
    def pct(p):
        acc = 0
        for k in sorted(h):
            acc += h[k]
            if acc >= p * n: return k
        return float("inf")
    return dict(n=n, p50=pct(0.5), p99=pct(0.99), p999=pct(0.999), max=mx, overflows=ovf)
expected = {"bring_up_complete", "enable_command", "stop_request", "damping_done"}
L = ["| run | active s | final mode | faults | mean / max error (rad) | deadline misses (max in a row) | skipped | held inputs (longest run / limit) | answer waits run out | plant late / dropped steps / stale answers / superseded SYNCs / boards tripped | wake-up p50 / p99 / p99.9 / max (µs) | cyclictest p50 / p99 / p99.9 / max (µs) | two-stage ID per cycle mean / worst (µs) | fallbacks | sim speed |",
     "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
ok = True
rt_runs = rt_held = 0
for name in names:
    d = os.path.join(out, name)
    if not os.path.exists(os.path.join(d, "servod.json")):
        L.append(f"| {name} | (no servod.json: see {name}.out) |"); ok = False
        rt_runs += name.startswith("rt_"); continue
    s = json.load(open(os.path.join(d, "servod.json"))); sim = json.load(open(os.path.join(d, "sim.json")))
    w, k, hi = s["wakeup_latency"], s["control_time"], s.get("held_inputs", {})
    faults = ", ".join(f"{a} {b}" for a, b in s["events"].items() if a not in expected) or "none"
    rt = s["clock"] == "realtime"
    held = faults == "none" and s["active_s"] >= dur - 0.01
    if rt:
        rt_runs += 1
        rt_held += held
        if not held: ok = False
    wk = f"{w['p50_us']:.0f} / {w['p99_us']:.0f} / {w['p999_us']:.0f} / {w['max_us']:.0f}" if rt else "n/a"
    cp = os.path.join(out, f"cyclictest_{name}.txt")
    if rt and os.path.exists(cp):
        c = cyc(cp); ct = f"{c['p50']} / {c['p99']} / {c['p999']} / {c['max']} ({c['n']} samples)"
    else: ct = "n/a"
    L.append(f"| {name} | {s['active_s']:.2f} | {s['final_mode']} | {faults} | {s['tracking_error_mean_rad']:.4f} / {s['tracking_error_max_rad']:.4f} | "
             f"{s['deadline_misses']} ({s['max_consecutive_misses']}) | {s['skipped_cycles']} | "
             f"{hi.get('total', '?')} ({hi.get('max_in_row', '?')} / {hi.get('limit', '?')}) | "
             f"{s.get('answer_wait_timeouts', 'n/a') if rt else 'n/a'} | "
             f"{sim.get('late_steps', 'n/a') if rt else 'n/a'} / {sim.get('dropped_steps', 'n/a') if rt else 'n/a'} / {sim.get('stale_answers', 'n/a') if rt else 'n/a'} / {sim.get('superseded_syncs', 'n/a') if rt else 'n/a'} / {sim.get('boards_tripped', 'n/a')} | {wk} | {ct} | "
             f"{k['mean_us']:.1f} / {k['max_us']:.0f} | {s['controller_fallbacks']} | {sim.get('speed', 0):.2f} |")
L += ["", "The paper (Zapolsky, Drumwright et al.): the two-stage ID took 1 ms per cycle on average and 36 ms at worst over sixty seconds of trotting."]
open(os.path.join(out, "summary.md"), "w").write("\n".join(L) + "\n")
print("\n".join(L))
print(f"benchmark_servo.sh: {rt_held} of {rt_runs} real-time runs held ACTIVE for the whole duration with no fault"
      + ("" if ok else " (see the faults column)"), file=sys.stderr)
PY
cat "$out/machine.txt"
if ((soak)); then
  "$here/build/ci/tools/hyq-servod/hyq-servod" --check-host --config "$here/config/hyq_servo_sim.yaml" \
    --check-host-seconds 10 | tee "$out/host_check.txt"
  echo "benchmark_servo.sh: the $soak_min-minute real-time soak (ctest -R hil_e2e.realtime_soak_10min) ..." >&2
  (cd "$here" && HYQ_SOAK=1 HYQ_SOAK_S=$((soak_min * 60)) ctest --preset ci -R 'hil_e2e\.realtime_soak_10min' \
    --output-on-failure) | tee "$out/soak.out"
fi
