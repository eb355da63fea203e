#!/usr/bin/python3
"""How far the daemon's base-state estimate is from the plant's truth in a HIL run.

usage: estimator_accuracy.py [--plot FILE.png] [--json FILE] [--summary] [--window T0:T1]
                             [--lcmtypes DIR] [--max-trot-vel-rms CM_S] [--max-trot-vel-max CM_S]
                             [--max-rest-vel-rms CM_S] [--max-yaw-drift MRAD] RUN_DIR

RUN_DIR is what `scripts/hil.sh --out RUN_DIR` leaves (lock-step, with the logger):
  telemetry.lcmlog  lcm-logger's record of the daemon's telemetry: HYQ_BASE_STATE (the estimate)
                    and HYQ_JOINT_STATE (the mode, the reference clock and the measured joints),
                    decoded with the python classes lcm-gen makes from lcmtypes/*.lcm
  truth.csv         hyq-sim --truth: the plant's base pose, velocity (vx_W, vy_W, vz_W, linear
                    in W) and joint angles every --truth-every steps; a truth.csv without the
                    velocity columns is differentiated (central differences of x, y, z)
  servod.json       the daemon's summary (its clock: lock-step only)

Alignment. In lock-step the daemon's clock and hyq-sim's are the same count of periods h: the
daemon's cycle stamped utime u (µs) sends SYNC u/h, which hyq-sim answers with the state after
u/h − 1 physics steps (docs/simulation.md, "Modes"), so the estimate of cycle u describes the
plant at simulated time

    t = u · 1e-6 − h,

h = 1 ms (measured from the telemetry: Δutime / Δcycle). The script checks this on the joint
angles: HYQ_JOINT_STATE's measured q of cycle u equals truth.csv's q at t within the encoders'
resolution (half a count, 24 µrad, plus their noise); it stops with a message naming the offset
that fits when it does not (a real-time run, a log of another run). Truth rows are every
--truth-every steps (hil.sh: 10); an estimate between two rows is compared with the truth
interpolated linearly (the orientation normalised): run hyq-sim with --truth-every 1
(`hil.sh --sim-arg --truth-every --sim-arg 1`) for the truth at every estimate.

Phases, from HYQ_JOINT_STATE (mode, reference_time_s), as the daemon's motion sequencer runs them
(servo/reference/motion_sequencer.h):
  stand_up  ACTIVE, the reference clock at 0: the posture move up from the resting crouch
  trot      ACTIVE, the reference clock running: the reference gait (the trot, or whatever
            --reference ran)
  sit_down  ACTIVE, the reference clock stopped (a sample's clock equal to the one before): the
            move down to the crouch
  rest      DAMPING, STANDBY or STOPPED after a sit-down: the robot resting in its crouch
(not counted: before the first ACTIVE, the robot on its stand; FAULT; whatever follows an ACTIVE
that ended without a sit-down, e.g. the damping after a fault.)

Per phase: the velocity error (estimate − truth, world frame) per axis, RMS and largest |·| in
cm/s, with the truth's own RMS; height error (cm); roll and pitch error (mrad, ZYX Euler angles);
yaw drift (mrad): the change of the yaw error from the phase's first to its last sample. When
HYQ_BASE_STATE carries velocity_std_m_s (the estimate's standard deviation per axis), the share
of samples whose error is within ±2σ, and the plot draws the ±2σ band.

Options:
  --plot FILE.png   velocity estimate vs truth (x, y) and the errors over time, phases shaded
  --json FILE       every number as JSON
  --summary         one line: trot vx/vy RMS and max, rest vx/vy RMS, trot yaw drift
  --window T0:T1    only samples with simulated time in [T0, T1] s
  --lcmtypes DIR    the .lcm files to decode with (default: this tree's lcmtypes/)
  --max-trot-vel-rms CM_S, --max-trot-vel-max CM_S, --max-rest-vel-rms CM_S (each of x and y),
  --max-yaw-drift MRAD (|trot yaw drift|): exit 1 naming every figure above its bound

Exit status: 0 ok; 1 a bound exceeded (or its phase missing); 2 bad arguments, a missing or
unreadable file, or a run that cannot be aligned.
"""
import argparse
import bisect
import csv
import glob
import importlib
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_LCMTYPES = os.path.join(HERE, "..", "lcmtypes")
PROG = "estimator_accuracy"
LCM_SYNC = 0xEDA1DA01
MODE_ACTIVE, MODE_FAULT = 2, 4                  # servo::ServoMode (servo/common/servo_types.h)
PHASES = ("stand_up", "trot", "sit_down", "rest")
AXES = ("x", "y", "z")
# the joint-angle check of the alignment: the encoders' half count plus noise, with room
ALIGN_TOL_RAD = 1e-3


class Usage(Exception):
    """A bad argument, a missing file or a run that cannot be aligned: exit 2 with the message."""


# --- reading ---------------------------------------------------------------------------------

def lcm_types(lcmtypes_dir):
    """The hyq_lcm message classes lcm-gen --python makes from lcmtypes_dir/*.lcm, as
    {fingerprint: class}."""
    files = sorted(glob.glob(os.path.join(lcmtypes_dir, "*.lcm")))
    if not files:
        raise Usage(f"{lcmtypes_dir}: no .lcm files (--lcmtypes)")
    gen = shutil.which("lcm-gen")
    if gen is None:
        raise Usage("lcm-gen not found on PATH (Debian: liblcm-bin)")
    out = tempfile.mkdtemp(prefix="hyq_lcmtypes_")
    p = subprocess.run([gen, "--python", "--ppath", out] + files, stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, text=True)
    if p.returncode != 0:
        raise Usage(f"lcm-gen --python {lcmtypes_dir}: exit {p.returncode}: {p.stderr.strip()}")
    sys.path.insert(0, out)
    for name in list(sys.modules):
        if name == "hyq_lcm" or name.startswith("hyq_lcm."):
            del sys.modules[name]
    pkg = importlib.import_module("hyq_lcm")
    types = {}
    for name in dir(pkg):
        t = getattr(pkg, name)
        if hasattr(t, "_get_packed_fingerprint"):
            types[t._get_packed_fingerprint()] = t
    sys.path.remove(out)
    shutil.rmtree(out, ignore_errors=True)
    return types


def lcm_events(path):
    """(channel, data) of each event of an lcm-logger file; a damaged stretch is skipped to the
    next sync word, a truncated last event dropped."""
    with open(path, "rb") as f:
        data = f.read()
    sync = struct.pack(">I", LCM_SYNC)
    i, n = 0, len(data)
    while i + 28 <= n:
        if data[i:i + 4] != sync:
            j = data.find(sync, i + 1)
            if j < 0:
                return
            i = j
            continue
        _, _, _, clen, dlen = struct.unpack_from(">IqqII", data, i)
        end = i + 28 + clen + dlen
        if end > n:
            return
        channel = data[i + 28:i + 28 + clen].decode("utf-8", "replace")
        yield channel, data[i + 28 + clen:end]
        i = end


def read_log(path, types):
    """HYQ_BASE_STATE and HYQ_JOINT_STATE messages of the log, each sorted by cycle."""
    wanted = {"HYQ_BASE_STATE": "lcmt_hyq_base_state", "HYQ_JOINT_STATE": "lcmt_hyq_joint_state"}
    by_name = {t.__name__: t for t in types.values()}
    out = {ch: [] for ch in wanted}
    foreign = {}
    for channel, data in lcm_events(path):
        if channel not in wanted:
            continue
        t = types.get(data[:8])
        if t is None or t.__name__ != wanted[channel]:
            foreign[channel] = foreign.get(channel, 0) + 1
            continue
        out[channel].append(t.decode(data))
    for ch, name in wanted.items():
        if not out[ch]:
            why = (f"{foreign[ch]} messages with another fingerprint than lcmtypes' {name} (a log "
                   "of another version of the message? --lcmtypes)") if ch in foreign else "none"
            raise Usage(f"{path}: no {ch} messages decoded ({why})")
        out[ch].sort(key=lambda m: m.cycle)
    if "lcmt_hyq_base_state" not in by_name:
        raise Usage("lcmtypes: no lcmt_hyq_base_state")
    return out["HYQ_BASE_STATE"], out["HYQ_JOINT_STATE"]


def read_truth(path):
    """truth.csv as {column: numpy array}; vx_W, vy_W, vz_W by central differences of x, y, z
    when the file has no velocity columns."""
    with open(path) as f:
        rows = list(csv.reader(f))
    if len(rows) < 3:
        raise Usage(f"{path}: expected a header and at least two rows, found {len(rows)} lines")
    head = rows[0]
    for c in ("t", "x", "y", "z", "qw", "qx", "qy", "qz"):
        if c not in head:
            raise Usage(f"{path}: no column '{c}' (not hyq-sim --truth output?)")
    body = np.array([[float(v) for v in r] for r in rows[1:] if len(r) == len(head)])
    cols = {c: body[:, k] for k, c in enumerate(head)}
    if "vx_W" not in cols:
        t = cols["t"]
        for a in AXES:
            cols[f"v{a}_W"] = np.gradient(cols[a], t)
        cols["_differentiated"] = True
    return cols


# --- geometry --------------------------------------------------------------------------------

def euler_zyx(qw, qx, qy, qz):
    """(roll, pitch, yaw) of unit quaternions w, x, y, z (arrays), ZYX convention."""
    roll = np.arctan2(2 * (qw * qx + qy * qz), 1 - 2 * (qx * qx + qy * qy))
    pitch = np.arcsin(np.clip(2 * (qw * qy - qz * qx), -1.0, 1.0))
    yaw = np.arctan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
    return roll, pitch, yaw


def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


# --- alignment -------------------------------------------------------------------------------

def period_s(joints):
    """h from the telemetry: Δutime / Δcycle over the log."""
    a, b = joints[0], joints[-1]
    if b.cycle == a.cycle:
        raise Usage("HYQ_JOINT_STATE: a single cycle, no period to measure")
    return 1e-6 * (b.utime - a.utime) / (b.cycle - a.cycle)


def truth_at(truth, t):
    """The truth at simulated times t (array): {column: array}, rows interpolated linearly
    between the two around t (exact where a row is at t); and the share of t with an exact row."""
    tt = truth["t"]
    k = np.clip(np.searchsorted(tt, t), 1, len(tt) - 1)
    t0, t1 = tt[k - 1], tt[k]
    w = np.clip((t - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0, 1.0)
    exact = (np.abs(t - t0) < 1e-7) | (np.abs(t - t1) < 1e-7)
    out = {}
    for c, v in truth.items():
        if isinstance(v, np.ndarray):
            out[c] = (1 - w) * v[k - 1] + w * v[k]
    # the quaternion: the same sign as the earlier row, then normalised
    q0 = np.stack([truth[c][k - 1] for c in ("qw", "qx", "qy", "qz")])
    q1 = np.stack([truth[c][k] for c in ("qw", "qx", "qy", "qz")])
    q1 = np.where(np.sum(q0 * q1, axis=0) < 0, -q1, q1)
    q = (1 - w) * q0 + w * q1
    q /= np.linalg.norm(q, axis=0)
    for i, c in enumerate(("qw", "qx", "qy", "qz")):
        out[c] = q[i]
    return out, float(np.mean(exact)) if len(t) else 0.0


def check_alignment(joints, truth, h):
    """{'matched', 'samples', 'max_rad'}: of the joint-state samples that fall on a truth row at
    t = utime − h, how many have every valid joint's |q_measured − q_truth| (input_status 0)
    within ALIGN_TOL_RAD, and the
    largest of those errors. The offset of one period must fit best of −5..11 periods (RMS over
    the samples) and at 95 % of them (a few may differ: an input the daemon held, its last cycle
    after STOPPED); else raises Usage naming the offset that fits best."""
    qcols = [c for c in truth if isinstance(truth[c], np.ndarray) and c.startswith("q_")]
    if len(qcols) != 12:
        return None  # a truth without joint angles: nothing to check against
    tt = truth["t"]
    Q = np.stack([truth[c] for c in qcols], axis=1)

    def errors(offset_steps):
        errs = []
        for m in joints:
            t = 1e-6 * m.utime - offset_steps * h
            k = bisect.bisect_left(tt, t - 1e-7)
            if k < len(tt) and abs(tt[k] - t) < 1e-7:
                valid = np.array(getattr(m, "input_status", [0] * 12)) == 0
                if valid.any():
                    errs.append(float(np.max(np.abs(np.array(m.q_rad) - Q[k])[valid])))
        return np.array(errs)

    e = errors(1)
    if len(e) == 0:
        raise Usage("no HYQ_JOINT_STATE sample falls on a truth.csv row at t = utime − h: "
                    "the two do not come from one lock-step run")
    rms = {k: float(np.sqrt(np.mean(x * x))) for k in range(-5, 12) for x in [errors(k)] if len(x)}
    best = min(rms, key=rms.get)
    matched = float(np.mean(e <= ALIGN_TOL_RAD))
    if rms[1] > rms[best] * (1 + 1e-9) + 1e-12 or matched < 0.95:
        raise Usage(f"the measured joint angles differ from truth.csv's at t = utime − h (RMS "
                    f"{rms[1]:.3g} rad, {100 * matched:.0f} % within {ALIGN_TOL_RAD:g}); "
                    f"t = utime − {best} h fits best (RMS {rms[best]:.3g} rad): not a lock-step "
                    "run of this truth?")
    ok = e[e <= ALIGN_TOL_RAD]
    return {"matched": int(len(ok)), "samples": int(len(e)), "max_rad": float(np.max(ok))}


# --- phases ----------------------------------------------------------------------------------

def phase_of_joint_samples(joints):
    """The phase of each HYQ_JOINT_STATE sample (None: not counted)."""
    phases = []
    active = False
    prev_ref = None
    sat = False  # the last ACTIVE stretch ended in a sit-down
    for m in joints:
        if m.mode == MODE_ACTIVE:
            if not active:
                sat, prev_ref = False, None
            active = True
            r = m.reference_time_s
            if r <= 0.0:
                p = "stand_up"
            elif sat or (prev_ref is not None and prev_ref > 0.0 and r == prev_ref):
                sat, p = True, "sit_down"
            else:
                p = "trot"
            prev_ref = r
        else:
            active = False
            p = "rest" if sat and m.mode != MODE_FAULT else None
        phases.append(p)
    return phases


# --- the figures -----------------------------------------------------------------------------

def stats(e):
    return {"rms": float(np.sqrt(np.mean(e * e))), "max": float(np.max(np.abs(e)))}


def figures(d, mask):
    """The numbers of one phase: samples where mask."""
    out = {"samples": int(np.sum(mask))}
    if not out["samples"]:
        return out
    t = d["t"][mask]
    out["t0_s"], out["t1_s"] = float(t[0]), float(t[-1])
    out["velocity_cm_s"] = {a: stats(100 * d["ev"][i][mask]) for i, a in enumerate(AXES)}
    out["true_velocity_rms_cm_s"] = {
        a: float(np.sqrt(np.mean((100 * d["vt"][i][mask]) ** 2))) for i, a in enumerate(AXES)}
    out["height_cm"] = stats(100 * d["ez"][mask])
    out["roll_mrad"] = stats(1e3 * d["eroll"][mask])
    out["pitch_mrad"] = stats(1e3 * d["epitch"][mask])
    eyaw = d["eyaw"][mask]
    out["yaw_drift_mrad"] = float(1e3 * wrap(eyaw[-1] - eyaw[0]))
    if d["std"] is not None:
        within = {}
        for i, a in enumerate(AXES):
            s = d["std"][i][mask]
            within[a] = float(np.mean(np.abs(d["ev"][i][mask]) <= 2 * s))
        out["within_2sigma"] = within
    return out


def analyse(run_dir, lcmtypes_dir, window, bias_after_s=5.0):
    for f in ("telemetry.lcmlog", "truth.csv"):
        if not os.path.isfile(os.path.join(run_dir, f)):
            why = (" (hil.sh records it unless --no-logger)" if f == "telemetry.lcmlog" else
                   " (hil.sh records it: hyq-sim --truth)")
            raise Usage(f"{os.path.join(run_dir, f)}: missing{why}")
    servod = os.path.join(run_dir, "servod.json")
    if os.path.isfile(servod):
        with open(servod) as f:
            clock = json.load(f).get("clock")
        if clock not in (None, "lockstep"):
            raise Usage(f"{servod}: clock '{clock}': only a lock-step run can be aligned with its "
                        "truth (the daemon's utime is then hyq-sim's simulated time)")
    types = lcm_types(lcmtypes_dir)
    base, joints = read_log(os.path.join(run_dir, "telemetry.lcmlog"), types)
    truth = read_truth(os.path.join(run_dir, "truth.csv"))
    h = period_s(joints)
    joint_check = check_alignment(joints, truth, h)

    # each estimate: its phase (the joint-state sample of its cycle, else the latest before it)
    jp = phase_of_joint_samples(joints)
    jc = [m.cycle for m in joints]
    phase = []
    for m in base:
        k = bisect.bisect_right(jc, m.cycle) - 1
        phase.append(jp[k] if k >= 0 else None)
    t = np.array([1e-6 * m.utime - h for m in base])
    inside = (t >= truth["t"][0] - 1e-9) & (t <= truth["t"][-1] + 1e-9)
    if window:
        inside &= (t >= window[0] - 1e-9) & (t <= window[1] + 1e-9)
    keep = np.nonzero(inside)[0]
    if len(keep) == 0:
        raise Usage("no estimate falls within the truth's time span (and --window)")
    base = [base[i] for i in keep]
    phase = [phase[i] for i in keep]
    t = t[keep]
    tr, exact_share = truth_at(truth, t)

    v_est = np.array([m.velocity_m_s for m in base]).T
    p_est = np.array([m.position_m for m in base]).T
    q_est = np.array([m.orientation_wxyz for m in base]).T
    v_true = np.stack([tr["vx_W"], tr["vy_W"], tr["vz_W"]])
    r_e, p_e, y_e = euler_zyx(*q_est)
    r_t, p_t, y_t = euler_zyx(tr["qw"], tr["qx"], tr["qy"], tr["qz"])
    has_std = hasattr(base[0], "velocity_std_m_s")
    d = {
        "t": t,
        "ev": v_est - v_true,
        "vt": v_true,
        "ve": v_est,
        "ez": p_est[2] - tr["z"],
        "eroll": wrap(r_e - r_t),
        "epitch": wrap(p_e - p_t),
        "eyaw": wrap(y_e - y_t),
        "std": np.array([m.velocity_std_m_s for m in base]).T if has_std else None,
        "phase": np.array([p or "" for p in phase]),
    }
    # the gyro bias: the estimate once the robot has stood still for bias_after_s (cumulative),
    # against the bias hyq-sim drew (sim.json's imu_bias_B), relative to its size
    bias = None
    sim_json = os.path.join(run_dir, "sim.json")
    true_bias = None
    if os.path.isfile(sim_json):
        with open(sim_json) as f:
            true_bias = json.load(f).get("imu_bias_B", {}).get("gyro_rad_s")
    if true_bias is not None and hasattr(base[0], "gyro_bias_rad_s"):
        still_s, at = 0.0, None
        for i in range(1, len(base)):
            if base[i].still:
                still_s += t[i] - t[i - 1]
            if still_s >= bias_after_s:
                at = i
                break
        b = np.array(true_bias)
        if at is not None and np.linalg.norm(b) > 0:
            est = np.array(base[at].gyro_bias_rad_s)
            bias = {"true_rad_s": b.tolist(), "estimate_rad_s": est.tolist(), "at_s": float(t[at]),
                    "still_s": bias_after_s,
                    "relative_error": float(np.linalg.norm(est - b) / np.linalg.norm(b))}
        else:
            bias = {"true_rad_s": b.tolist(), "estimate_rad_s": None, "still_s": bias_after_s,
                    "relative_error": None}
    result = {
        "run_dir": os.path.abspath(run_dir),
        "gyro_bias": bias,
        "alignment": {
            "rule": "t_sim = utime - h",
            "period_s": h,
            "joint_angle_check": joint_check,
            "truth_interval_s": float(np.median(np.diff(truth["t"]))),
            "truth_exact_share": exact_share,
            "truth_velocity": "differentiated" if truth.get("_differentiated") else "recorded",
        },
        "window_s": list(window) if window else None,
        "estimates": len(base),
        "velocity_std": has_std,
        "phases": {p: figures(d, d["phase"] == p) for p in PHASES},
    }
    return result, d


# --- output ----------------------------------------------------------------------------------

def fmt(x, digits=2):
    return "-" if x is None else f"{x:.{digits}f}"


def report(r):
    a = r["alignment"]
    jc = a["joint_angle_check"]
    check = ("no joint angles in the truth to check it on" if jc is None else
             f"the joint angles agree within {1e6 * jc['max_rad']:.1f} µrad at {jc['matched']} of "
             f"{jc['samples']} samples")
    lines = [f"estimator accuracy: {r['run_dir']}",
             f"  aligned at t_sim = utime - {1e3 * a['period_s']:.3f} ms ({check}); "
             f"truth every {1e3 * a['truth_interval_s']:.1f} ms, {100 * a['truth_exact_share']:.0f} % of the "
             f"estimates on a truth row, the rest interpolated; truth velocity {a['truth_velocity']}",
             f"  {'phase':9s} {'from':>6s} {'to':>6s} {'n':>5s} | velocity error RMS / max, cm/s "
             f"{'(true RMS)':>10s} | height cm | roll, pitch mrad RMS / max | yaw drift mrad"]
    for p in PHASES:
        f = r["phases"][p]
        if not f["samples"]:
            lines.append(f"  {p:9s} (no samples)")
            continue
        v = f["velocity_cm_s"]
        vel = "  ".join(f"{ax} {v[ax]['rms']:5.2f}/{v[ax]['max']:5.1f}" for ax in AXES)
        true = "/".join(f"{f['true_velocity_rms_cm_s'][ax]:.1f}" for ax in ("x", "y"))
        lines.append(
            f"  {p:9s} {f['t0_s']:6.2f} {f['t1_s']:6.2f} {f['samples']:5d} | {vel} ({true}) | "
            f"{f['height_cm']['rms']:.2f}/{f['height_cm']['max']:.1f} | "
            f"{f['roll_mrad']['rms']:.1f}/{f['roll_mrad']['max']:.1f}, "
            f"{f['pitch_mrad']['rms']:.1f}/{f['pitch_mrad']['max']:.1f} | {f['yaw_drift_mrad']:+.2f}")
        if "within_2sigma" in f:
            w = f["within_2sigma"]
            lines.append(f"  {'':9s} within ±2σ: " + ", ".join(f"{ax} {100 * w[ax]:.0f} %" for ax in AXES))
    b = r.get("gyro_bias")
    if b:
        if b["relative_error"] is None:
            lines.append(f"  gyro bias: the robot never stood still for {b['still_s']:g} s")
        else:
            lines.append("  gyro bias after {:g} s standing still (t {:.2f} s): estimate [{}] mrad/s, true [{}] "
                         "mrad/s, error {:.1f} % of the bias".format(
                             b["still_s"], b["at_s"], ", ".join(f"{1e3 * x:.3f}" for x in b["estimate_rad_s"]),
                             ", ".join(f"{1e3 * x:.3f}" for x in b["true_rad_s"]), 100 * b["relative_error"]))
    return "\n".join(lines)


def summary(r):
    tr, rest = r["phases"]["trot"], r["phases"]["rest"]
    parts = []
    if tr["samples"]:
        v = tr["velocity_cm_s"]
        parts.append(f"trot vx RMS {v['x']['rms']:.2f} max {v['x']['max']:.1f}, vy RMS {v['y']['rms']:.2f} "
                     f"max {v['y']['max']:.1f} cm/s")
    else:
        parts.append("no trot")
    if rest["samples"]:
        v = rest["velocity_cm_s"]
        parts.append(f"rest vx/vy RMS {v['x']['rms']:.2f}/{v['y']['rms']:.2f} cm/s")
    else:
        parts.append("no rest")
    if tr["samples"]:
        parts.append(f"yaw drift {tr['yaw_drift_mrad']:+.1f} mrad over the trot")
    return "estimator: " + "; ".join(parts)


def violations(r, a):
    """Each figure above its bound (or whose phase is missing), as a message."""
    out = []

    def check(phase, key, bound, flag, label):
        if bound is None:
            return
        f = r["phases"][phase]
        if not f["samples"]:
            out.append(f"{flag}: no {phase} phase in the run")
            return
        for ax in ("x", "y"):
            x = f["velocity_cm_s"][ax][key]
            if x > bound:
                out.append(f"{phase} v{ax} {label} {x:.2f} cm/s > {bound:g} ({flag})")

    check("trot", "rms", a.max_trot_vel_rms, "--max-trot-vel-rms", "RMS error")
    check("trot", "max", a.max_trot_vel_max, "--max-trot-vel-max", "largest error")
    check("rest", "rms", a.max_rest_vel_rms, "--max-rest-vel-rms", "RMS error")
    if a.max_gyro_bias_error is not None:
        b = r.get("gyro_bias")
        if not b or b["relative_error"] is None:
            out.append("--max-gyro-bias-error: no drawn bias in sim.json or no still period of "
                       f"{a.bias_after:g} s in the run")
        elif 100 * b["relative_error"] > a.max_gyro_bias_error:
            out.append(f"gyro bias error {100 * b['relative_error']:.1f} % > {a.max_gyro_bias_error:g} "
                       "(--max-gyro-bias-error)")
    if a.max_yaw_drift is not None:
        f = r["phases"]["trot"]
        if not f["samples"]:
            out.append("--max-yaw-drift: no trot phase in the run")
        elif abs(f["yaw_drift_mrad"]) > a.max_yaw_drift:
            out.append(f"trot yaw drift {f['yaw_drift_mrad']:+.2f} mrad, |·| > {a.max_yaw_drift:g} "
                       "(--max-yaw-drift)")
    return out


def plot(r, d, path):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        raise Usage(f"--plot needs matplotlib (/usr/bin/python3, python3-matplotlib): {e}")
    colours = {"stand_up": "#dddddd", "trot": "#d8ecd8", "sit_down": "#e8e0f0", "rest": "#dde6f2"}
    t = d["t"]
    fig, axs = plt.subplots(3, 1, figsize=(12, 9), sharex=True)
    for i, (ax, name) in enumerate(zip(axs[:2], ("vx", "vy"))):
        ax.plot(t, d["vt"][i], "k-", lw=1.0, label="truth")
        ax.plot(t, d["ve"][i], "C0-", lw=0.8, label="estimate")
        if d["std"] is not None:
            ax.fill_between(t, d["ve"][i] - 2 * d["std"][i], d["ve"][i] + 2 * d["std"][i],
                            color="C0", alpha=0.2, lw=0, label="estimate ±2σ")
        ax.set_ylabel(f"{name} (W), m/s")
        ax.legend(loc="upper right", fontsize=8)
    for i, a in enumerate(AXES):
        axs[2].plot(t, 100 * d["ev"][i], f"C{i}-", lw=0.8, label=f"v{a} error")
    if d["std"] is not None:
        for i, a in enumerate(("x", "y")):
            axs[2].fill_between(t, -200 * d["std"][i], 200 * d["std"][i], color=f"C{i}", alpha=0.12,
                                lw=0, label=f"±2σ v{a}")
    axs[2].set_ylabel("estimate − truth, cm/s")
    axs[2].set_xlabel("simulated time, s")
    axs[2].legend(loc="upper right", fontsize=8, ncol=3)
    for p in PHASES:
        f = r["phases"][p]
        if f["samples"]:
            for ax in axs:
                ax.axvspan(f["t0_s"], f["t1_s"], color=colours[p], zorder=0)
            axs[0].text(0.5 * (f["t0_s"] + f["t1_s"]), 1.0, p, transform=axs[0].get_xaxis_transform(),
                        ha="center", va="bottom", fontsize=8)
    tr = r["phases"]["trot"]
    if tr["samples"]:
        v = tr["velocity_cm_s"]
        fig.suptitle(f"base velocity: estimate vs truth; trot RMS vx {v['x']['rms']:.2f}, vy "
                     f"{v['y']['rms']:.2f} cm/s", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def window_arg(text):
    try:
        a, b = (float(x) for x in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected T0:T1 (simulated seconds), found '{text}'")
    if not a < b:
        raise argparse.ArgumentTypeError(f"expected T0 < T1, found '{text}'")
    return (a, b)


def main(argv=None):
    ap = argparse.ArgumentParser(
        prog="estimator_accuracy.py",
        description="The daemon's base-state estimate (HYQ_BASE_STATE) against hyq-sim's truth in "
                    "a lock-step HIL run (scripts/hil.sh --out RUN_DIR): per phase RMS and largest "
                    "errors of velocity, height, roll and pitch, and the yaw drift.",
        epilog="Exit status: 0 ok; 1 a bound exceeded; 2 bad arguments, missing files or a run "
               "that cannot be aligned. The module docstring says how the run is aligned.")
    ap.add_argument("run_dir", metavar="RUN_DIR")
    ap.add_argument("--plot", metavar="FILE.png")
    ap.add_argument("--json", metavar="FILE")
    ap.add_argument("--summary", action="store_true", help="only the one-line summary")
    ap.add_argument("--window", type=window_arg, metavar="T0:T1", help="simulated seconds")
    ap.add_argument("--lcmtypes", default=DEFAULT_LCMTYPES, metavar="DIR")
    ap.add_argument("--max-trot-vel-rms", type=float, metavar="CM_S")
    ap.add_argument("--max-trot-vel-max", type=float, metavar="CM_S")
    ap.add_argument("--max-rest-vel-rms", type=float, metavar="CM_S")
    ap.add_argument("--max-yaw-drift", type=float, metavar="MRAD")
    ap.add_argument("--bias-after", type=float, default=5.0, metavar="S",
                    help="compare the gyro bias once the estimator has found the robot still this long "
                         "(default 5)")
    ap.add_argument("--max-gyro-bias-error", type=float, metavar="PCT",
                    help="bound on |estimated - drawn gyro bias| / |drawn| (sim.json's imu_bias_B)")
    a = ap.parse_args(argv)
    try:
        if not os.path.isdir(a.run_dir):
            raise Usage(f"{a.run_dir}: not a directory")
        r, d = analyse(a.run_dir, a.lcmtypes, a.window, a.bias_after)
        if a.json:
            with open(a.json, "w") as f:
                json.dump(r, f, indent=2)
        if a.plot:
            plot(r, d, a.plot)
    except Usage as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return 2
    print(summary(r) if a.summary else report(r))
    bad = violations(r, a)
    for v in bad:
        print(f"{PROG}: {v}", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
