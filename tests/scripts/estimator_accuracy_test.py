#!/usr/bin/python3
"""scripts/estimator_accuracy.py on synthetic run dirs whose errors are known: a truth.csv, and a
telemetry.lcmlog written here with the hyq_lcm python classes (lcm-gen) holding HYQ_JOINT_STATE
(the phases, the measured joints) and HYQ_BASE_STATE (the truth plus chosen errors), the daemon's
utime one period ahead of the truth's simulated time as in lock-step.

Timeline (simulated s): STANDBY to 0.2 (not counted), stand-up to 1.2, trot to 5.2 (the reference
clock running), sit-down to 6.2 (the clock stopped), DAMPING to 8.2 (rest). Errors: trot vx
3 sin(4πt) cm/s (RMS 3/√2 over its 8 whole periods, largest 3), vy 1 cm/s, height 2 cm, roll
5 mrad, yaw 1 mrad/s (drift 3.999 mrad over the 3.999 s); stand-up vx 0.5 cm/s; rest vx 0.2,
vy −0.4 cm/s; sit-down none.

usage: estimator_accuracy_test.py [WORK_DIR]   (default: a temporary directory)
Prints PASS at the end; any failed check exits 1.
"""
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "scripts", "estimator_accuracy.py")
LCMTYPES = os.path.join(HERE, "..", "..", "lcmtypes")
sys.path.insert(0, os.path.dirname(SCRIPT))
import estimator_accuracy as ea  # noqa: E402

H = 0.001           # the period, s
BRINGUP = 7         # the daemon's cycles before its cycle 0: utime = (cycle + 7) ms
T_END = 8.2
failures = []


def check(what, ok, detail=""):
    print("%s: %s" % ("ok  " if ok else "FAIL", what))
    if not ok:
        failures.append(what)
        if detail:
            print(detail)


def near(what, x, expected, tol):
    check(f"{what}: {x!r} within {tol} of {expected}", x is not None and abs(x - expected) <= tol)


def phase_at(t):
    """(mode, reference_time_s) of the daemon at simulated time t."""
    if t < 0.2:
        return 1, 0.0
    if t < 1.2 - 1e-9:
        return 2, 0.0
    if t < 5.2 - 1e-9:
        return 2, round(t - 1.2 + 0.001, 6)
    if t < 6.2 - 1e-9:
        return 2, 4.0
    return 3, 4.0


def errors_at(t):
    """(ex, ey, ez, e_height, e_roll, e_yaw) of the estimate at simulated time t."""
    _, ref = phase_at(t)
    if phase_at(t)[0] == 2 and ref == 0.0 and t >= 0.2:          # stand-up
        return 0.005, 0, 0, 0, 0, 0
    if phase_at(t)[0] == 2 and 0 < ref and t < 5.2 - 1e-9:       # trot
        return 0.03 * math.sin(4 * math.pi * t), 0.01, 0, 0.02, 0.005, 0.001 * (t - 1.2)
    if phase_at(t)[0] == 3:                                      # rest
        return 0.002, -0.004, 0, 0, 0, 0
    return 0, 0, 0, 0, 0, 0


def quat(roll, pitch, yaw):
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return [cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy]


def truth_at(t):
    """The plant: position, velocity (W), Euler angles, 12 joint angles."""
    v = [0.2 + 0.05 * math.sin(t), 0.05 * math.cos(0.5 * t), 0.01 * math.sin(3 * t)]
    p = [0.2 * t - 0.05 * math.cos(t), 0.1 * math.sin(0.5 * t), 0.55 - 0.01 * math.cos(3 * t) / 3]
    e = [0.02 * math.sin(t), 0.01 * math.cos(t), 0.1 * t]
    q = [0.1 * j + 0.3 * math.sin(2 * t + j) for j in range(12)]
    return p, v, e, q


def lcm_event(num, channel, data):
    c = channel.encode()
    return struct.pack(">IqqII", 0xEDA1DA01, num, num, len(c), len(data)) + c + data


def make_run(d, types, truth_every=1, joint_lag_steps=0, with_std=None, clock="lockstep"):
    """A run dir in d; with_std: the velocity_std_m_s to publish (m/s) when the types have it."""
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "servod.json"), "w") as f:
        json.dump({"clock": clock}, f)
    names = ["t", "x", "y", "z", "qw", "qx", "qy", "qz"] + [f"q_j{j}" for j in range(12)] + \
            ["holding"] + ["vx_W", "vy_W", "vz_W", "wx_B", "wy_B", "wz_B"]
    steps = int(round(T_END / H))
    with open(os.path.join(d, "truth.csv"), "w") as f:
        f.write(",".join(names) + "\n")
        for k in range(truth_every, steps + 1, truth_every):
            t = k * H
            p, v, e, q = truth_at(t)
            row = [t] + p + quat(*e) + q + [0] + v + [0, 0, 0]
            f.write(",".join(repr(x) for x in row) + "\n")
    by_name = {c.__name__: c for c in types.values()}
    Base, Joint = by_name["lcmt_hyq_base_state"], by_name["lcmt_hyq_joint_state"]
    out = bytearray()
    n = 0
    for cycle in range(0, steps - BRINGUP):
        utime = (cycle + BRINGUP) * 1000
        t = utime * 1e-6 - H               # what the cycle's measurements describe
        mode, ref = phase_at(t)
        if not (2.5 < t < 2.6 and cycle % 3 == 0):  # a few joint states lost by the logger
            m = Joint()
            m.utime, m.cycle, m.mode, m.reference_time_s = utime, cycle, mode, ref
            m.q_rad = truth_at(t - joint_lag_steps * H)[3]
            out += lcm_event(n, "HYQ_JOINT_STATE", m.encode())
            n += 1
        p, v, e, _ = truth_at(t)
        ex, ey, ez, eh, er, eyaw = errors_at(t)
        b = Base()
        b.utime, b.cycle = utime, cycle
        b.position_m = [p[0], p[1], p[2] + eh]
        b.orientation_wxyz = quat(e[0] + er, e[1], e[2] + eyaw)
        b.velocity_m_s = [v[0] + ex, v[1] + ey, v[2] + ez]
        b.angular_velocity_rad_s = [0.0, 0.0, 0.1]
        if with_std is not None:
            b.velocity_std_m_s = [with_std] * 3
        out += lcm_event(n, "HYQ_BASE_STATE", b.encode())
        n += 1
        out += lcm_event(n, "HYQ_OTHER", b"\x00" * 12)  # another channel: skipped
        n += 1
    out += b"\xed\xa1\xda\x01\x00\x00"  # a truncated last event
    with open(os.path.join(d, "telemetry.lcmlog"), "wb") as f:
        f.write(bytes(out))


# the message version the runs below are written with (unless a check names another): the
# base state without its uncertainty fields, as an older daemon published it
OLD_LCMTYPES = None
UNCERTAINTY_FIELDS = ("position_std_m", "velocity_std_m_s", "orientation_std_rad", "gyro_bias_rad_s",
                      "accel_bias_m_s2", "still")


def old_lcmtypes(work):
    """A copy of lcmtypes/ whose lcmt_hyq_base_state has none of the estimator's uncertainty fields."""
    lt = os.path.join(work, "lcmtypes_old")
    shutil.copytree(LCMTYPES, lt, dirs_exist_ok=True)
    path = os.path.join(lt, "lcmt_hyq_base_state.lcm")
    lines = [line for line in open(path)
             if not any(f" {f}[" in line or f" {f};" in line for f in UNCERTAINTY_FIELDS)]
    open(path, "w").writelines(lines)
    return lt


def run(*args):
    args = [str(a) for a in args]
    if "--lcmtypes" not in args and OLD_LCMTYPES:
        args += ["--lcmtypes", OLD_LCMTYPES]
    p = subprocess.run(["/usr/bin/python3", SCRIPT] + args, stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, text=True)
    return p.returncode, p.stdout, p.stderr


def main():
    if len(sys.argv) > 1:
        work = sys.argv[1]
        os.makedirs(work, exist_ok=True)
        return check_all(work)
    work = tempfile.mkdtemp(prefix="estimator_accuracy_")
    try:
        return check_all(work)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def check_all(work):
    global OLD_LCMTYPES
    OLD_LCMTYPES = old_lcmtypes(work)
    types = ea.lcm_types(OLD_LCMTYPES)

    # --- known errors, the truth at every step --------------------------------------------
    d = os.path.join(work, "run")
    make_run(d, types)
    js = os.path.join(work, "run.json")
    rc, out, err = run(d, "--json", js)
    check(f"exit 0 (found {rc})", rc == 0, out + err)
    r = json.load(open(js))
    a = r["alignment"]
    near("period", a["period_s"], H, 1e-12)
    check("every estimate on a truth row", a["truth_exact_share"] == 1.0)
    check("the joint angles agree everywhere", a["joint_angle_check"]["matched"] ==
          a["joint_angle_check"]["samples"] > 7000, str(a))
    ph = r["phases"]
    expected = {p: 0 for p in ea.PHASES}
    for cycle in range(0, int(round(T_END / H)) - BRINGUP):
        t = (cycle + BRINGUP) * 1000 * 1e-6 - H
        mode, ref = phase_at(t)
        p = (None if mode == 1 else "rest" if mode == 3 else "stand_up" if ref == 0 else
             "trot" if t < 5.2 - 1e-9 else "sit_down")
        if p:
            expected[p] += 1
    check("samples per phase as the timeline has them", all(
        ph[p]["samples"] == expected[p] for p in ea.PHASES) and expected["trot"] == 4000,
        str([(ph[p]["samples"], expected[p]) for p in ea.PHASES]))
    tr = ph["trot"]
    near("trot vx RMS", tr["velocity_cm_s"]["x"]["rms"], 3 / math.sqrt(2), 1e-6)
    near("trot vx max", tr["velocity_cm_s"]["x"]["max"], 3.0, 1e-9)
    near("trot vy RMS", tr["velocity_cm_s"]["y"]["rms"], 1.0, 1e-9)
    near("trot vy max", tr["velocity_cm_s"]["y"]["max"], 1.0, 1e-9)
    near("trot vz RMS", tr["velocity_cm_s"]["z"]["rms"], 0.0, 1e-9)
    near("trot height RMS", tr["height_cm"]["rms"], 2.0, 1e-9)
    near("trot roll RMS", tr["roll_mrad"]["rms"], 5.0, 1e-6)
    near("trot pitch max", tr["pitch_mrad"]["max"], 0.0, 1e-6)
    near("trot yaw drift", tr["yaw_drift_mrad"], 3.999, 1e-6)
    near("trot from", tr["t0_s"], 1.2, 1e-9)
    near("trot to", tr["t1_s"], 5.199, 1e-9)
    near("trot true vx RMS", tr["true_velocity_rms_cm_s"]["x"], 20.0, 1.0)
    near("stand-up vx RMS", ph["stand_up"]["velocity_cm_s"]["x"]["rms"], 0.5, 1e-9)
    near("sit-down vx max", ph["sit_down"]["velocity_cm_s"]["x"]["max"], 0.0, 1e-9)
    near("rest vx RMS", ph["rest"]["velocity_cm_s"]["x"]["rms"], 0.2, 1e-9)
    near("rest vy RMS", ph["rest"]["velocity_cm_s"]["y"]["rms"], 0.4, 1e-9)
    check("no velocity_std: no ±2σ share", "within_2sigma" not in tr and r["velocity_std"] is False)
    check("the table names every phase", all(p in out for p in ea.PHASES), out)

    rc, out, _ = run(d, "--summary")
    check(f"--summary: one line (exit {rc})", rc == 0 and out.count("\n") == 1, out)
    check("--summary: the trot, the rest and the yaw drift",
          "trot vx RMS 2.12 max 3.0, vy RMS 1.00 max 1.0 cm/s" in out and
          "rest vx/vy RMS 0.20/0.40 cm/s" in out and "yaw drift +4.0 mrad" in out, out)

    # --- the bounds -----------------------------------------------------------------------
    rc, out, err = run(d, "--summary", "--max-trot-vel-rms", 2.0)
    check(f"--max-trot-vel-rms 2.0: exit 1 (found {rc})", rc == 1, err)
    check("names the figure and the flag", "trot vx RMS error 2.12 cm/s > 2 (--max-trot-vel-rms)" in err
          and "vy" not in err, err)
    rc, _, err = run(d, "--max-trot-vel-rms", 2.2, "--max-trot-vel-max", 3.1, "--max-rest-vel-rms", 0.5,
                     "--max-yaw-drift", 4.1)
    check(f"bounds above every figure: exit 0 (found {rc})", rc == 0, err)
    rc, _, err = run(d, "--max-trot-vel-max", 2.5, "--max-rest-vel-rms", 0.3, "--max-yaw-drift", 3.5)
    check(f"three bounds below: exit 1 (found {rc})", rc == 1, err)
    check("each violated figure named", "trot vx largest error 3.00 cm/s > 2.5 (--max-trot-vel-max)" in err
          and "rest vy RMS error 0.40 cm/s > 0.3 (--max-rest-vel-rms)" in err
          and "trot yaw drift +4.00 mrad, |·| > 3.5 (--max-yaw-drift)" in err
          and "rest vx" not in err, err)

    # --- a window -------------------------------------------------------------------------
    rc, out, _ = run(d, "--json", js, "--window", "1.45:1.95")
    r = json.load(open(js))
    check(f"--window: exit 0 (found {rc})", rc == 0)
    check("--window: only the trot's samples in it", r["phases"]["trot"]["samples"] == 501 and
          r["phases"]["rest"]["samples"] == 0, str({p: r["phases"][p]["samples"] for p in ea.PHASES}))
    near("--window: one whole period, vx RMS", r["phases"]["trot"]["velocity_cm_s"]["x"]["rms"],
         3 / math.sqrt(2), 0.01)
    rc, _, err = run(d, "--window", "2:1")
    check(f"--window 2:1: exit 2 (found {rc})", rc == 2 and "T0 < T1" in err, err)

    # --- the truth every 10 steps: interpolated -------------------------------------------
    d10 = os.path.join(work, "run10")
    make_run(d10, types, truth_every=10)
    rc, out, _ = run(d10, "--json", js)
    r = json.load(open(js))
    check(f"truth every 10 steps: exit 0 (found {rc})", rc == 0, out)
    near("a tenth of the estimates on a truth row", r["alignment"]["truth_exact_share"], 0.1, 0.01)
    near("interpolated: trot vx RMS", r["phases"]["trot"]["velocity_cm_s"]["x"]["rms"], 3 / math.sqrt(2), 1e-3)
    near("interpolated: trot vy max", r["phases"]["trot"]["velocity_cm_s"]["y"]["max"], 1.0, 1e-3)
    near("interpolated: yaw drift", r["phases"]["trot"]["yaw_drift_mrad"], 3.999, 1e-3)

    # --- the truth without its velocity columns: differentiated ---------------------------
    dd = os.path.join(work, "run_novel")
    shutil.copytree(d, dd, dirs_exist_ok=True)
    rows = [line.rstrip("\n").split(",") for line in open(os.path.join(dd, "truth.csv"))]
    with open(os.path.join(dd, "truth.csv"), "w") as f:
        for row in rows:
            f.write(",".join(row[:-6]) + "\n")
    rc, out, _ = run(dd, "--json", js)
    r = json.load(open(js))
    check(f"no velocity columns: exit 0, differentiated (found {rc})",
          rc == 0 and r["alignment"]["truth_velocity"] == "differentiated", out)
    near("differentiated: trot vx RMS", r["phases"]["trot"]["velocity_cm_s"]["x"]["rms"], 3 / math.sqrt(2), 0.01)

    # --- velocity_std_m_s in HYQ_BASE_STATE: the ±2σ share and band -----------------------
    lt = LCMTYPES  # the present version has it
    std_types = ea.lcm_types(lt)
    ds = os.path.join(work, "run_std")
    make_run(ds, std_types, with_std=0.01)
    rc, out, err = run(ds, "--lcmtypes", lt, "--json", js)
    r = json.load(open(js))
    check(f"velocity_std: exit 0 (found {rc})", rc == 0, err)
    w = r["phases"]["trot"].get("within_2sigma", {})
    near("within ±2σ = 2 cm/s of a 3 sin error: (2/π) asin(2/3)", w.get("x"), 2 / math.pi * math.asin(2 / 3), 0.01)
    near("within ±2σ of a 1 cm/s error: all", w.get("y"), 1.0, 1e-12)
    check("the table gives the ±2σ share", "within ±2σ" in out, out)
    rc, _, err = run(ds, "--summary")
    check(f"a log of another message version: exit 2 naming it (found {rc})",
          rc == 2 and "another fingerprint" in err, err)

    # --- the plot, with and without the band ----------------------------------------------
    try:
        import matplotlib  # noqa: F401
        for run_dir, extra in ((d, []), (ds, ["--lcmtypes", lt])):
            png = os.path.join(work, os.path.basename(run_dir) + ".png")
            rc, _, err = run(run_dir, "--plot", png, *extra)
            check(f"--plot {os.path.basename(png)}: exit 0 and a PNG (found {rc})", rc == 0 and
                  open(png, "rb").read(8) == b"\x89PNG\r\n\x1a\n", err)
    except ImportError:
        print("skip: no matplotlib, --plot not checked")

    # --- runs that cannot be aligned, missing files ---------------------------------------
    dl = os.path.join(work, "run_lag")
    make_run(dl, types, joint_lag_steps=1)
    rc, _, err = run(dl, "--summary")
    check(f"joint angles one step older: exit 2 (found {rc})", rc == 2 and "t = utime − 2 h fits best" in err, err)
    dr = os.path.join(work, "run_rt")
    make_run(dr, types, clock="realtime")
    rc, _, err = run(dr)
    check(f"a real-time run: exit 2 (found {rc})", rc == 2 and "only a lock-step run" in err, err)
    os.remove(os.path.join(dr, "telemetry.lcmlog"))
    rc, _, err = run(dr)
    check(f"no telemetry.lcmlog: exit 2 naming it (found {rc})",
          rc == 2 and "telemetry.lcmlog: missing" in err and "--no-logger" in err, err)
    rc, _, err = run(os.path.join(work, "nonexistent"))
    check(f"no run dir: exit 2 (found {rc})", rc == 2 and "not a directory" in err, err)
    rc, out, _ = run("--help")
    check(f"--help: exit 0 (found {rc})", rc == 0 and "RUN_DIR" in out and "--max-trot-vel-rms" in out, out)

    if failures:
        print(f"{len(failures)} check(s) failed")
        return 1
    print("PASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
