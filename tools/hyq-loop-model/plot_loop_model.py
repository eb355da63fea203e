#!/usr/bin/python3
"""Bode and Nyquist plots of hyq-loop-model's loops, from its --json file.

usage: plot_loop_model.py MODEL.json OUT.png

OUT.png: per joint type (columns haa, hfe, kfe) the open loop L(e^{jwT}) of the table's loops
(the leg with the least margin per phase and plant) with no extra delay: |L|, arg L, and the
Nyquist plot near -1 (dashed: with the report's extra cycles). With the realistic plant also
OUT_hydraulics.png: the hydraulic actuator's measured responses (dots) and their fits (lines),
A (set-point -> torque) and Z (joint velocity -> torque lost), for the lf leg in each phase.
"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

TYPES = ["haa", "hfe", "kfe"]
STYLE = {
    ("swing", "ideal"): ("tab:blue", "-"),
    ("swing", "realistic"): ("tab:blue", ":"),
    ("stance", "ideal"): ("tab:red", "-"),
    ("stance", "realistic"): ("tab:red", ":"),
    ("stand", "ideal"): ("tab:green", "-"),
    ("stand", "realistic"): ("tab:green", ":"),
}


def loops(model, path):
    fig, ax = plt.subplots(3, 3, figsize=(15, 12))
    k = model["settings"]["report_extra_cycles"]
    for row in model["table"]:
        col = TYPES.index(row["type"])
        color, ls = STYLE[(row["phase"], row["plant"])]
        cycles = row["max_extra_cycles_exact"]
        label = "%s %s (%s): %s extra cycles" % (
            row["phase"], row["plant"], row["joint"], "unstable" if cycles < 0 else cycles)
        r0, rk = row["response"]
        f = np.array(r0["f_hz"])
        L = np.array(r0["re"]) + 1j * np.array(r0["im"])
        Lk = np.array(rk["re"]) + 1j * np.array(rk["im"])
        ax[0, col].loglog(f, np.abs(L), color=color, ls=ls, label=label)
        ax[1, col].semilogx(f, np.degrees(np.unwrap(np.angle(L))), color=color, ls=ls)
        near = np.abs(L) < 4
        ax[2, col].plot(L.real[near], L.imag[near], color=color, ls=ls)
        near_k = np.abs(Lk) < 4
        ax[2, col].plot(Lk.real[near_k], Lk.imag[near_k], color=color, ls="--", lw=0.8)
    for col, t in enumerate(TYPES):
        ax[0, col].axhline(1.0, color="k", lw=0.5)
        ax[0, col].set_title("%s: |L|" % t.upper())
        ax[0, col].legend(fontsize=7)
        ax[1, col].axhline(-180.0, color="k", lw=0.5)
        ax[1, col].set_title("arg L (deg)")
        ax[1, col].set_xlabel("Hz")
        ax[2, col].plot([-1], [0], "kx")
        ax[2, col].add_patch(plt.Circle((0, 0), 1.0, fill=False, lw=0.5))
        ax[2, col].set_xlim(-3, 1.5)
        ax[2, col].set_ylim(-2.5, 2.5)
        ax[2, col].set_aspect("equal")
        ax[2, col].set_title("Nyquist near -1 (dashed: +%d cycles)" % k)
    fig.suptitle("hyq-loop-model: %s, controller %s" % (model["config"], model["controller"]))
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def hydraulics(model, path):
    h = model["hydraulics"]
    fig, ax = plt.subplots(2, 3, figsize=(15, 8))
    for col, t in enumerate(TYPES):
        for phase, color in [("swing", "tab:blue"), ("stance", "tab:red"), ("stand", "tab:green")]:
            a = h[phase]["lf_" + t]
            for r, key, name in [(0, "setpoint_f_re_im_fitre_fitim", "A"),
                                 (1, "motion_f_re_im_fitre_fitim", "Z (N m s/rad)")]:
                p = np.array(a[key])
                meas = p[:, 1] + 1j * p[:, 2]
                fit = p[:, 3] + 1j * p[:, 4]
                ax[r, col].semilogx(p[:, 0], meas.real, "o", ms=2, color=color)
                ax[r, col].semilogx(p[:, 0], fit.real, "-", color=color,
                                    label="%s Re (%.0f N m)" % (phase, a["operating_torque_Nm"]))
                ax[r, col].semilogx(p[:, 0], meas.imag, "^", ms=2, color=color)
                ax[r, col].semilogx(p[:, 0], fit.imag, "--", color=color, label="%s Im" % phase)
                ax[r, col].set_title("lf_%s: %s" % (t, name))
        ax[0, col].legend(fontsize=7)
        ax[1, col].set_xlabel("Hz")
    fig.suptitle("the realistic plant's hydraulic actuator, measured (markers) and fitted (lines)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    model = json.load(open(sys.argv[1]))
    loops(model, sys.argv[2])
    if "hydraulics" in model:
        out = sys.argv[2][:-4] if sys.argv[2].endswith(".png") else sys.argv[2]
        hydraulics(model, out + "_hydraulics.png")


if __name__ == "__main__":
    main()
