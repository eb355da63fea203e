#!/usr/bin/python3
"""Figures in the style of the paper from hyq-experiment's CSV files.

  /usr/bin/python3 tools/hyq-experiment/plot.py DIR      (DIR: hyq-experiment --out DIR)

fig1_torques.png    torque profiles, Stage I only vs Stage I + II, through contact changes
fig2_mu0.1.png      norm of the joint tracking error, trot (top) and Figure-Eight (bottom),
                    PID / no-slip ID / two-stage ID, with a histogram at right, mu = 0.1
fig3_mu1.0.png      the same on mu = 1.0
fig_patch_mu.png    a trot across an icy patch, the estimated (and Stage I's) vs the
                    true mu per foot over time, and the tracking error with mu assumed,
                    given by an oracle and estimated
"""
import csv
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STYLE = {  # the paper's: PID green double dash, ours blue solid, no-slip red dash-dot-dash
    "pid": dict(color="tab:green", linestyle=(0, (6, 2, 6, 6)), label="PID"),
    "two_stage": dict(color="tab:blue", linestyle="-", label="two-stage ID (ours)"),
    "noslip": dict(color="tab:red", linestyle=(0, (8, 2, 2, 2)), label="no-slip ID"),
}


def load(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    cols = {k: [float(r[k]) for r in rows] for k in rows[0].keys()}
    return cols


def error_figure(out_dir, mu, filename):
    fig, axes = plt.subplots(2, 2, figsize=(10, 6), gridspec_kw={"width_ratios": [4, 1]})
    for row, task in enumerate(["trot", "eight"]):
        ax, hist = axes[row]
        for ctl in ["pid", "noslip", "two_stage"]:
            path = os.path.join(out_dir, f"{task}_mu{mu}_{ctl}.csv")
            if not os.path.exists(path):
                continue
            d = load(path)
            ax.plot(d["t"], d["error_norm"], linewidth=1.2, **STYLE[ctl])
            hist.hist(d["error_norm"], bins=40, orientation="horizontal", histtype="step",
                      color=STYLE[ctl]["color"], density=True)
        ax.set_ylabel("‖q_ref − q‖ (rad)")
        ax.set_title(("trot" if task == "trot" else "one Figure-Eight cycle") + f", μ = {mu}")
        ax.set_yscale("log")
        hist.set_yscale("log")
        hist.set_xlabel("density")
        hist.set_ylim(ax.get_ylim())
    axes[1][0].set_xlabel("time (s)")
    axes[0][0].legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, filename), dpi=110)
    plt.close(fig)


def torque_figure(out_dir):
    a = load(os.path.join(out_dir, "fig1_stage1.csv"))
    b = load(os.path.join(out_dir, "fig1_two_stage.csv"))
    fig, axes = plt.subplots(3, 1, figsize=(10, 7), sharex=True)
    names = ["LF HAA", "LF HFE", "LF KFE"]
    t = a["t"]
    # shade the contact phases: number of stance feet in the reference
    feet = [sum(int(a[f"stance{i}"][k]) for i in range(4)) for k in range(len(t))]
    for j, ax in enumerate(axes):
        ax.plot(t, a[f"tau{j}"], color="tab:orange", linewidth=0.9, label="Stage I only")
        ax.plot(t, b[f"tau{j}"], color="tab:blue", linewidth=1.2, label="Stage I + II")
        ax.set_ylabel(f"{names[j]} τ (N m)")
        start = t[0]
        for k in range(1, len(t)):
            if feet[k] == 4 and feet[k - 1] != 4:
                start = t[k]
            if feet[k] != 4 and feet[k - 1] == 4:
                ax.axvspan(start, t[k], color="0.9", zorder=0)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title("Fig. 1: torques through contact changes (grey: four feet, white: two)")
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "fig1_torques.png"), dpi=110)
    plt.close(fig)


FEET = ["lf", "rf", "lh", "rh"]
SOURCES = {"assumed": dict(color="tab:red", label="μ = 1 assumed"),
           "oracle": dict(color="tab:green", label="true μ per foot (oracle)"),
           "estimated": dict(color="tab:blue", label="μ estimated online")}


def patch_figure(out_dir, seed="s1"):
    est = load(os.path.join(out_dir, f"patch_estimated_{seed}.csv"))
    fig, axes = plt.subplots(5, 1, figsize=(10, 11), sharex=True,
                             gridspec_kw={"height_ratios": [1, 1, 1, 1, 1.4]})
    t = est["t"]
    for leg, ax in enumerate(axes[:4]):
        ax.plot(t, est[f"mu_true{leg}"], color="black", linewidth=1.4, label="true μ under the foot")
        ax.plot(t, est[f"mu_estimate{leg}"], color="tab:blue", linewidth=1.1, label="estimate μ̂")
        ax.plot(t, est[f"mu_control{leg}"], color="tab:blue", linestyle=":", linewidth=1.0,
                label="Stage I's μ, (1 − margin) μ̂")
        slip = [v if int(s) else float("nan") for v, s in zip(est[f"mu_estimate{leg}"], est[f"slipping{leg}"])]
        ax.plot(t, slip, "o", color="tab:red", markersize=2.5, label="slip detected")
        # stance shading: the reference's stance
        start = None
        for k in range(len(t)):
            on = int(est[f"stance{leg}"][k])
            if on and start is None:
                start = t[k]
            if (not on or k == len(t) - 1) and start is not None:
                ax.axvspan(start, t[k], color="0.93", zorder=0)
                start = None
        ax.set_ylabel(f"{FEET[leg]} μ")
        ax.set_ylim(0, 1.1)
    axes[0].legend(loc="lower left", fontsize=7, ncol=4)
    axes[0].set_title(f"Trot across an icy patch (μ = 0.1) and off it ({seed}; grey: stance)")
    ax = axes[4]
    for src, style in SOURCES.items():
        path = os.path.join(out_dir, f"patch_{src}_{seed}.csv")
        if os.path.exists(path):
            d = load(path)
            ax.plot(d["t"], d["error_norm"], linewidth=1.0, **style)
    ax.set_yscale("log")
    ax.set_ylabel("‖q_ref − q‖ (rad)")
    ax.set_xlabel("time (s)")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "fig_patch_mu.png"), dpi=100)
    plt.close(fig)


def main():
    if len(sys.argv) != 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__)
        return 0 if len(sys.argv) == 2 else 2
    out_dir = sys.argv[1]
    made = []
    if os.path.exists(os.path.join(out_dir, "fig1_stage1.csv")):
        torque_figure(out_dir)
        made.append("fig1_torques.png")
    for mu, name in [("0.1", "fig2_mu0.1.png"), ("1.0", "fig3_mu1.0.png")]:
        if any(os.path.exists(os.path.join(out_dir, f"{t}_mu{mu}_{c}.csv"))
               for t in ["trot", "eight"] for c in STYLE):
            error_figure(out_dir, mu, name)
            made.append(name)
    if os.path.exists(os.path.join(out_dir, "patch_estimated_s1.csv")):
        patch_figure(out_dir)
        made.append("fig_patch_mu.png")
    if not made:
        print(f"plot.py: no hyq-experiment CSV files in {out_dir}", file=sys.stderr)
        return 1
    print("wrote " + ", ".join(os.path.join(out_dir, m) for m in made))
    return 0


if __name__ == "__main__":
    sys.exit(main())
