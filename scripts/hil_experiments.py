#!/usr/bin/python3
"""The paper's mu = 0.1 experiments through the loop: hyq-sim + hyq-servod on virtual CAN
(scripts/hil.sh, lock-step, through scripts/hyq_runs.py), beside the in-process runs of
hyq-experiment.

    /usr/bin/python3 scripts/hil_experiments.py [--out DIR] [--quick] [--resume] [--build DIR]

Runs, for trot (6 s) and Figure-Eight (5 s, as hyq-experiment) on mu = 0.1 with pid, pd_gravity,
noslip and two_stage, each with its tuned gains (the shipped configuration's, from
scripts/tune_gains.py; hyq-experiment's default --gains tuned):
  - in-process (hyq-experiment --scenario ..., true state, ideal actuators, no noise, no bus),
  - HIL "full": actuator lag 5 ms (hyq-sim default), load-cell noise, IMU noise, seeds 1 and 2,
  - HIL ablations (seed 1): noise off; actuator lag off; both off.
Writes DIR/runs/<name>/ (hil.sh output), DIR/results.json, and the markdown tables DIR/tables.md
(docs/hil_experiments.md quotes them) and the figure DIR/hil_mu0.1.png (if matplotlib).
Every number comes from these runs; nothing is hard-coded. The feet's slip speed comes from the
plant's state (truth.csv) and tools/hyq-kinematics (the feet of the servo's own model).
"""
import argparse, json, math, os, subprocess

import hyq_runs

HERE = hyq_runs.HERE
BUILD = hyq_runs.DEFAULT_BUILD
MU = 0.1
REFS = {"trot": 6.0, "eight": 0.5 + 4.0 + 0.5}  # ACTIVE time, s (the Figure-Eight's as hyq-experiment's)
CTRLS = hyq_runs.CONTROLLERS
# name -> (plant of hyq_runs.PLANTS, hyq-sim's seed or None for its default, 1)
VARIANTS = {
    "full": ("full", None),
    "full_seed2": ("full", 2),
    "no_noise": ("no_noise", None),
    "no_lag": ("no_lag", None),
    "no_lag_no_noise": ("no_lag_no_noise", None),
}
LEGS = hyq_runs.LEGS


def sim_args(variant):
    plant, seed = VARIANTS[variant]
    return hyq_runs.PLANTS[plant] + (["--seed", str(seed)] if seed is not None else [])


def slip_from_truth(out, t0, t1):
    """Mean tangential speed of the material contact point of touching feet for t0 <= t < t1: the
    point of the foot's sphere touching the ground at one row of truth.csv, carried with the lower
    leg to the next row."""
    truth = hyq_runs.read_truth(out)
    feet = hyq_runs.feet(BUILD, os.path.join(out, "truth.csv"))
    t = truth["t"]
    dt = t[1] - t[0] if len(t) > 1 else 1e-3

    def frame(leg, k):
        p = [feet[f"{leg}_{a}"][k] for a in "xyz"]
        c = [feet[f"{leg}_c{a}"][k] for a in "xyz"]
        R = [[feet[f"{leg}_R{i}{j}"][k] for j in range(3)] for i in range(3)]
        return p, c, R

    total, n = 0.0, 0
    for k in range(len(t) - 1):
        if t[k] < t0 or t[k] >= t1 or truth["holding"][k] > 0.5:
            continue
        for leg in LEGS:
            touching = truth[f"{leg}_touching"]
            if touching[k] < 0.5 or touching[k + 1] < 0.5:
                continue
            p0, c0, R0 = frame(leg, k)
            p1, _, R1 = frame(leg, k + 1)
            b = [sum(R0[i][a] * (c0[i] - p0[i]) for i in range(3)) for a in range(3)]  # body-fixed
            c1 = [p1[a] + sum(R1[a][i] * b[i] for i in range(3)) for a in range(3)]
            total += math.hypot(c1[0] - c0[0], c1[1] - c0[1]) / dt
            n += 1
    return total / n if n else float("nan"), dt


def main():
    global BUILD
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.join(HERE, "hil-experiments"))
    ap.add_argument("--quick", action="store_true", help="only the 'full' variant")
    ap.add_argument("--resume", action="store_true", help="reuse runs already in DIR/runs made by the same command")
    ap.add_argument("--build", default=BUILD, help=f"the build tree (default {BUILD})")
    a = ap.parse_args()
    BUILD = os.path.abspath(a.build)
    for tool in ("hyq-experiment", "hyq-kinematics"):
        if not os.path.exists(os.path.join(BUILD, "tools", tool, tool)):
            ap.error(f"--build: no tools/{tool}/{tool} under {BUILD} (build the project first)")
    os.makedirs(a.out, exist_ok=True)
    log = open(os.path.join(a.out, "commands.log"), "a" if a.resume else "w")

    # in-process (hyq-experiment): the reference numbers of docs/experiments.md
    inproc_dir = os.path.join(a.out, "inprocess")
    cmd = [os.path.join(BUILD, "tools", "hyq-experiment", "hyq-experiment"), "--out", inproc_dir]
    for r in REFS:
        for c in CTRLS:
            cmd += ["--scenario", f"{r}_mu{MU}_{c}"]
    log.write("$ " + " ".join(cmd) + "\n")
    subprocess.run(cmd, check=True, capture_output=True)
    inproc = json.load(open(os.path.join(inproc_dir, "results.json")))["scenarios"]

    results = {"settings": {"mu": MU, "load_cell_noise_Nm": hyq_runs.LOAD_CELL_NOISE,
                            "imu_noise": hyq_runs.IMU_NOISE, "actuator_tau_s": hyq_runs.ACTUATOR_TAU,
                            "clock": "lockstep"},
               "inprocess": {}, "hil": {}}
    for r in REFS:
        for c in CTRLS:
            x = inproc[f"{r}_mu{MU}_{c}"]
            results["inprocess"][f"{r}_{c}"] = {
                "mean_error_rad": x["mean_error_rad"], "max_error_rad": x["max_error_rad"],
                "fell": x["fell"], "fell_at_s": x["fell_at_s"], "mean_slip_m_s": x["mean_slip_speed_m_s"],
                "qp_mean_us": x["qp_us"]["mean"], "qp_max_us": x["qp_us"]["max"],
                "fallbacks": x["fallbacks"]}

    variants = ["full"] if a.quick else list(VARIANTS)
    for v in variants:
        for r, dur in REFS.items():
            for c in CTRLS:
                name = f"{r}_{c}_{v}"
                out = os.path.join(a.out, "runs", name)
                run = hyq_runs.run(out, c, build=BUILD, reference=hyq_runs.REFERENCES[r], duration_s=dur, mu=MU,
                                   sim_args=["--truth-every", "1"] + sim_args(v), retries=1, log=log,
                                   reuse=a.resume)
                s, sim, h = run.summaries()
                t0 = sim.get("released_at_s", 0.0)
                slip, dt = slip_from_truth(out, t0, h["t_stop_s"])
                res = {
                    "command": " ".join(run.command), "exit": run.exit,
                    "active_s": s["active_s"], "final_mode": s["final_mode"],
                    "mean_error_rad": s["tracking_error_mean_rad"], "max_error_rad": s["tracking_error_max_rad"],
                    "fell_while_active": h["fell_while_active"],
                    "fell_at_active_s": (sim["fell_at_s"] - t0) if h["fell_while_active"] else None,
                    "mean_slip_m_s": slip,
                    "qp_mean_us": s["qp_time_mean_us"], "qp_max_us": s["qp_time_max_us"],
                    "fallbacks": s["controller_fallbacks"],
                    "control_p50_us": s["control_time"]["p50_us"], "control_p999_us": s["control_time"]["p999_us"],
                    "control_max_us": s["control_time"]["max_us"],
                    "events": s["events"], "speed": sim.get("speed"),
                }
                results["hil"][name] = res
                print(f"{name:32s} err {res['mean_error_rad']:.4f}/{res['max_error_rad']:.4f} rad  "
                      f"fell {res['fell_while_active']}  slip {slip:.3f} m/s  qp {res['qp_mean_us']:.1f}/"
                      f"{res['qp_max_us']:.0f} us  fb {res['fallbacks']}  mode {res['final_mode']}", flush=True)
    json.dump(results, open(os.path.join(a.out, "results.json"), "w"), indent=1)
    write_tables(results, a.out, variants)
    plot(results, a.out, variants)


def pct(a, b):
    return 100.0 * (a - b) / b


def fell_txt(fell, at):
    return f"**falls at {at:.2f} s**" if fell else "no"


def table(L, heading, columns):
    """Appends a markdown table's heading, header row and separator row to L."""
    L.append(heading)
    L.append("| " + " | ".join(columns) + " |")
    L.append("|" + "---|" * len(columns))


def error_cell(mean_error, fell, fell_at, slip):
    """'mean error (falls at s); mean slip', as the one-factor table shows a run."""
    return f"{mean_error:.4f}" + (f" (falls {fell_at:.2f})" if fell else "") + f"; {slip:.3f}"


def write_tables(R, out, variants):
    L = []
    name = {"trot": "trot (6 s)", "eight": "Figure-Eight (5 s)"}
    table(L, "### Main table: mu = 0.1, in-process vs through the loop (HIL 'full')\n",
          ["scenario", "controller", "in-process mean / max error (rad)", "in-process slip (m/s)",
           "in-process fell", "HIL mean / max error (rad)", "HIL slip (m/s)", "HIL fell while active",
           "HIL QP mean / max (µs)", "HIL fallbacks"])
    for r in REFS:
        for c in CTRLS:
            i, h = R["inprocess"][f"{r}_{c}"], R["hil"][f"{r}_{c}_full"]
            L.append(f"| {name[r]} | {c} | {i['mean_error_rad']:.4f} / {i['max_error_rad']:.3f} | {i['mean_slip_m_s']:.3f} | "
                     f"{fell_txt(i['fell'], i['fell_at_s'])} | {h['mean_error_rad']:.4f} / {h['max_error_rad']:.3f} | "
                     f"{h['mean_slip_m_s']:.3f} | {fell_txt(h['fell_while_active'], h['fell_at_active_s'] or 0)} | "
                     f"{h['qp_mean_us']:.1f} / {h['qp_max_us']:.0f} | {h['fallbacks']} |")
    table(L, "\n### Two-stage ID vs PID, PD + gravity compensation and no-slip ID (mean tracking error)\n",
          ["scenario", "comparison", "in-process", "HIL full (seed 1)", "HIL full (seed 2)"])
    for r in REFS:
        for other in ["pid", "pd_gravity", "noslip"]:
            i = pct(R["inprocess"][f"{r}_two_stage"]["mean_error_rad"], R["inprocess"][f"{r}_{other}"]["mean_error_rad"])
            cells = []
            for v in ["full", "full_seed2"]:
                if f"{r}_two_stage_{v}" in R["hil"]:
                    cells.append(f"{pct(R['hil'][f'{r}_two_stage_{v}']['mean_error_rad'], R['hil'][f'{r}_{other}_{v}']['mean_error_rad']):+.1f} %")
                else:
                    cells.append("—")
            L.append(f"| {name[r]} | two-stage vs {other} | {i:+.1f} % | " + " | ".join(cells) + " |")
    if len(variants) > 1:
        table(L, "\n### One factor at a time (mean error rad; fell while active at s; mean slip m/s)\n",
              ["scenario", "controller", "in-process (none of the factors)", "HIL lag off + noise off",
               "HIL noise off", "HIL lag off", "HIL full", "HIL full, seed 2"])
        for r in REFS:
            for c in CTRLS:
                i = R["inprocess"][f"{r}_{c}"]
                cells = [error_cell(i["mean_error_rad"], i["fell"], i["fell_at_s"], i["mean_slip_m_s"])]
                for v in ["no_lag_no_noise", "no_noise", "no_lag", "full", "full_seed2"]:
                    h = R["hil"][f"{r}_{c}_{v}"]
                    cells.append(error_cell(h["mean_error_rad"], h["fell_while_active"],
                                            h["fell_at_active_s"], h["mean_slip_m_s"]))
                L.append(f"| {name[r]} | {c} | " + " | ".join(cells) + " |")
    table(L, "\n### Servo-cycle controller time in the HIL 'full' runs (µs, wall clock of the lock-step daemon)\n",
          ["scenario", "controller", "control p50", "control p99.9", "control max",
           "lock-step speed (sim s / wall s)"])
    for r in REFS:
        for c in CTRLS:
            h = R["hil"][f"{r}_{c}_full"]
            L.append(f"| {name[r]} | {c} | {h['control_p50_us']:.1f} | {h['control_p999_us']:.1f} | {h['control_max_us']:.0f} | {h['speed']:.2f} |")
    open(os.path.join(out, "tables.md"), "w").write("\n".join(L) + "\n")
    print("\n".join(L))


def plot(R, out, variants):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("no matplotlib: no figure")
        return
    cols = [("in-process", None)] + [(v, v) for v in ["no_lag_no_noise", "no_noise", "no_lag", "full"] if v in variants]
    fig, axs = plt.subplots(1, 2, figsize=(11, 4))
    for ax, r in zip(axs, REFS):
        w = 0.8 / len(cols)
        for k, (label, v) in enumerate(cols):
            ys, falls = [], []
            for c in CTRLS:
                d = R["inprocess"][f"{r}_{c}"] if v is None else R["hil"][f"{r}_{c}_{v}"]
                ys.append(d["mean_error_rad"])
                falls.append(d["fell"] if v is None else d["fell_while_active"])
            xs = [j + (k - (len(cols) - 1) / 2) * w for j in range(len(CTRLS))]
            bars = ax.bar(xs, ys, w, label=label)
            for x, y, f in zip(xs, ys, falls):
                if f:
                    ax.text(x, y, "fell", ha="center", va="bottom", fontsize=7, rotation=90)
        ax.set_xticks(range(len(CTRLS)), CTRLS)
        ax.set_yscale("log")
        ax.set_ylabel("mean ‖q_ref − q‖ (rad)")
        ax.set_title({"trot": "trot 6 s, μ = 0.1", "eight": "Figure-Eight, μ = 0.1"}[r])
    axs[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "hil_mu0.1.png"), dpi=110)
    print("figure", os.path.join(out, "hil_mu0.1.png"))


if __name__ == "__main__":
    main()
