#!/usr/bin/python3
"""The steered HIL run (hil_e2e_test.sh steer) judged against what was commanded.

    steered_run.py OUT_DIR [--plot PNG] [--max-position-error 0.25] [--max-yaw-error 0.2]

OUT_DIR holds servod.json (the daemon's summary: its events carry the virtual time of the enable
and of every applied set-velocity command), sim.json (released_at_s: the simulator's time of the
enable) and truth.csv (hyq-sim --truth: t, base x y z qw qx qy qz, ...). The commanded path is
the trot reference's rule replayed (docs/steering.md): the fixed forward profile until the first
command, then per axis a cubic Hermite ramp from the velocity and acceleration at the command to
the clamped target, T = max(1.5 |dv| / (a_max - 0.75 |a0|), 0.1 s); the pose is its integral in
the heading frame. At the end of ACTIVE the robot's base (truth) must be within
--max-position-error of the commanded path's length from the commanded position, and its yaw
within --max-yaw-error rad of the commanded yaw. Exit 0 when it is, 1 otherwise.
"""
import argparse, csv, json, math, os, re, sys

# the defaults of servo/reference/reference.h (TrotParams) and config/hyq_servo.yaml
STRIDE, FREQ, START, RAMP = 0.14, 1.4, 0.5, 1.0
VMAX, AMAX = (0.4, 0.2, 0.5), (0.5, 0.3, 0.8)


def min_jerk(x):
    if x <= 0: return 0.0, 0.0
    if x >= 1: return 1.0, 0.0
    return x**3 * (10 - 15 * x + 6 * x * x), 30 * x * x * (1 - 2 * x + x * x)


class Ramp:
    def __init__(self, t0, v0, a0, v1, amax):
        a0 = max(-amax, min(amax, a0))
        self.t0, self.v0, self.a0, self.v1 = t0, v0, a0, v1
        self.T = max(1.5 * abs(v1 - v0) / (amax - 0.75 * abs(a0)), 0.1)

    def at(self, t):
        if t >= self.t0 + self.T: return self.v1, 0.0
        s, T = (t - self.t0) / self.T, self.T
        v = (2*s**3 - 3*s*s + 1) * self.v0 + (s**3 - 2*s*s + s) * T * self.a0 + (-2*s**3 + 3*s*s) * self.v1
        a = ((6*s*s - 6*s) * self.v0 + (3*s*s - 4*s + 1) * T * self.a0 + (-6*s*s + 6*s) * self.v1) / T
        return v, a


def commanded_path(commands, t_end, dt=1e-3):
    """commands: [(t_ref, vx, vy, wz)]; returns [(t, x, y, yaw)] in the start's heading frame"""
    ramps = None
    v_default = STRIDE * FREQ
    def velocity(t):
        if ramps is None:
            s, ds = min_jerk((t - START) / RAMP)
            return [(v_default * s, v_default * ds / RAMP), (0.0, 0.0), (0.0, 0.0)]
        return [r.at(t) for r in ramps]
    x = y = yaw = 0.0
    path, pending, t = [(0.0, 0.0, 0.0, 0.0)], sorted(commands), 0.0
    while t < t_end - 1e-12:
        while pending and pending[0][0] <= t + 1e-12:
            tc, *target = pending.pop(0)
            t0 = max(tc, START)
            now = velocity(t0)
            ramps = [Ramp(t0, now[i][0], now[i][1], max(-VMAX[i], min(VMAX[i], target[i])), AMAX[i])
                     for i in range(3)]
        (vx, _), (vy, _), (wz, _) = velocity(t + 0.5 * dt)  # midpoint rule
        yaw_mid = yaw + 0.5 * dt * wz
        x += dt * (vx * math.cos(yaw_mid) - vy * math.sin(yaw_mid))
        y += dt * (vx * math.sin(yaw_mid) + vy * math.cos(yaw_mid))
        yaw += dt * wz
        t += dt
        path.append((t, x, y, yaw))
    return path


def yaw_of(qw, qx, qy, qz):
    return math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--plot")
    ap.add_argument("--max-position-error", type=float, default=0.25)
    ap.add_argument("--max-yaw-error", type=float, default=0.2)
    a = ap.parse_args()
    s = json.load(open(os.path.join(a.out, "servod.json")))
    sim = json.load(open(os.path.join(a.out, "sim.json")))
    log = s["event_log"]
    enable = [e for e in log if e["from"] == "standby" and e["to"] == "active"]
    if not enable:
        print("steered_run: FAIL: the daemon never became active"); return 1
    # the reference's clock starts after the stand-up and stops where the sit-down begins (its
    # event); the sit-down brakes the base to rest v T / 2 further on (T = 0.3 s), at rest after
    t_enable = enable[0]["time_s"] + s.get("stand_up_s", 0.0)
    commands = []
    for e in log:
        m = re.match(r"velocity = (\S+) m/s (\S+) m/s (\S+) rad/s", e["detail"])
        if e["reason"] == "command_applied" and m:
            commands.append((e["time_s"] - t_enable, *map(float, m.groups())))
    t_active = s["active_s"]
    sit = [e for e in log if e["detail"] == "sitting down to the crouch first"]
    t_ref = sit[0]["time_s"] - t_enable if sit else t_active - s.get("stand_up_s", 0.0)
    path = commanded_path(commands, t_ref)
    if sit and len(path) > 1:  # the braking drift along the last velocity
        (ta, xa, ya, _), (tb, xb, yb, yawb) = path[-2], path[-1]
        path.append((tb + 0.3, xb + 0.15 * (xb - xa) / (tb - ta), yb + 0.15 * (yb - ya) / (tb - ta), yawb))
    rows = [list(map(float, r[:8])) for r in csv.reader(open(os.path.join(a.out, "truth.csv")))
            if r and r[0][0].isdigit()]
    t0 = sim["released_at_s"]
    start = min(rows, key=lambda r: abs(r[0] - t0))
    end = min(rows, key=lambda r: abs(r[0] - (t0 + t_active)))
    yaw0 = yaw_of(*start[4:8])
    c0, s0 = math.cos(yaw0), math.sin(yaw0)
    def to_start(r):  # truth in the frame of the robot at the enable
        dx, dy = r[1] - start[1], r[2] - start[2]
        return c0 * dx + s0 * dy, -s0 * dx + c0 * dy, yaw_of(*r[4:8]) - yaw0
    got = to_start(end)
    want = path[-1][1:]
    length = sum(math.hypot(q[1] - p[1], q[2] - p[2]) for p, q in zip(path, path[1:]))
    err = math.hypot(got[0] - want[0], got[1] - want[1])
    yaw_err = (got[2] - want[2] + math.pi) % (2 * math.pi) - math.pi
    min_z = min(r[3] for r in rows if t0 <= r[0] <= t0 + t_active)
    print("steered_run: commands (reference time s, vx m/s, vy m/s, wz rad/s): " +
          ", ".join("(%.2f, %.2f, %.2f, %.2f)" % c for c in commands))
    print(f"steered_run: after {t_active:.2f} s active: commanded x {want[0]:.3f} m y {want[1]:.3f} m "
          f"yaw {want[2]:.3f} rad (path {length:.2f} m); robot x {got[0]:.3f} m y {got[1]:.3f} m "
          f"yaw {got[2]:.3f} rad; position error {err:.3f} m = {100 * err / max(length, 1e-9):.1f} % "
          f"of the path (limit {100 * a.max_position_error:.0f} %), yaw error {yaw_err:.3f} rad "
          f"(limit {a.max_yaw_error}); lowest base height while active {min_z:.3f} m")
    if a.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        truth = [to_start(r) for r in rows if t0 <= r[0] <= t0 + t_active]
        fig, ax = plt.subplots(figsize=(6, 5))
        ax.plot([p[1] for p in path], [p[2] for p in path], "--", color="tab:blue",
                label="commanded (set-velocity vx, vy, wz at the dots)")
        ax.plot([p[0] for p in truth], [p[1] for p in truth], color="tab:orange",
                label="simulated robot (hyq-sim truth)")
        for p, style in ((path[-1][1:], "tab:blue"), (got, "tab:orange")):
            ax.annotate("", xy=(p[0] + 0.12 * math.cos(p[2]), p[1] + 0.12 * math.sin(p[2])),
                        xytext=(p[0], p[1]), arrowprops=dict(arrowstyle="->", color=style))
        for c in commands:
            k = min(range(len(path)), key=lambda i: abs(path[i][0] - c[0]))
            ax.plot(path[k][1], path[k][2], "o", color="tab:blue", ms=4)
            ax.annotate(f"set ({c[1]:g} m/s, {c[2]:g} m/s, {c[3]:g} rad/s)", (path[k][1], path[k][2]),
                        textcoords="offset points", xytext=(4, -12), fontsize=8)
        ax.set_xlabel("x at enable (m)")
        ax.set_ylabel("y at enable (m)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
        ax.set_title(f"Steered trot, {t_active:.1f} s active: end error {err:.2f} m, yaw {yaw_err:+.2f} rad",
                     fontsize=9)
        fig.tight_layout()
        fig.savefig(a.plot, dpi=110)
        print(f"steered_run: wrote {a.plot}")
    ok = err <= a.max_position_error * length and abs(yaw_err) <= a.max_yaw_error and length > 0.5
    print(f"steered_run: {'ok' if ok else 'FAIL'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
