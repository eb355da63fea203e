#!/usr/bin/python3
"""Figures from the CSVs hyq-lcm-export wrote (one per channel) into DIR:

  joint_tracking.png   q and q_ref of the 12 joints (HYQ_JOINT_STATE)
  joint_torques.png    commanded (HYQ_JOINT_TORQUE) and measured (HYQ_JOINT_STATE) torques
  timing_histogram.png cycle work time and wake-up latency (HYQ_TIMING)
  events_timeline.png  safety events and mode changes (HYQ_EVENT)

usage: plot_lcm_log.py DIR [--prefix HYQ_]
A figure whose channel is absent is skipped (and said so). Needs python3-matplotlib (Debian).
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

JOINTS = ["lf_haa", "lf_hfe", "lf_kfe", "rf_haa", "rf_hfe", "rf_kfe",
          "lh_haa", "lh_hfe", "lh_kfe", "rh_haa", "rh_hfe", "rh_kfe"]
MODES = ["init", "standby", "active", "damping", "fault", "stopped"]


def read(path):
    """Columns by field name (the unit suffix " (unit)" stripped): name -> list of strings."""
    if not os.path.exists(path):
        return None
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:  # an empty file (an export cut short): no figure, not a traceback
        return None
    names = [h.rsplit(" (", 1)[0] for h in rows[0]]
    cols = {n: [] for n in names}
    for r in rows[1:]:
        for n, v in zip(names, r):
            cols[n].append(v)
    return cols


def num(cols, name):
    return [float(v) for v in cols[name]]


def time_s(cols):
    t = num(cols, "utime")
    return [(x - t[0]) * 1e-6 for x in t] if t else t


def joint_figure(title, plot_joint):
    """A 4 x 3 grid, one panel per joint: plot_joint(ax, joint) draws it; legend on the first."""
    fig, axes = plt.subplots(4, 3, figsize=(12, 10), sharex=True)
    fig.suptitle(title)
    for ax, j in zip(axes.flat, JOINTS):
        plot_joint(ax, j)
        ax.set_title(j, fontsize=9)
    fig.axes[0].legend(fontsize=8)
    for ax in fig.axes[-3:]:
        ax.set_xlabel("time (s)")
    return fig


def channel(out, prefix, name, figure):
    """The columns of DIR/<prefix><name>.csv, or None (and says there is no `figure`) when the
    file is absent or has no rows."""
    cols = read(os.path.join(out, prefix + name + ".csv"))
    if cols and cols["utime"]:
        return cols
    print("plot: no %s%s.csv, no %s" % (prefix, name, figure))
    return None


def save(fig, out, name, made):
    fig.tight_layout()
    fig.savefig(os.path.join(out, name), dpi=80)
    plt.close(fig)
    made.append(name)


def main():
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__)
        return 0 if len(sys.argv) >= 2 else 2
    out = sys.argv[1]
    prefix = sys.argv[sys.argv.index("--prefix") + 1] if "--prefix" in sys.argv else "HYQ_"
    made = []

    js = channel(out, prefix, "JOINT_STATE", "joint tracking figure")
    if js:
        t = time_s(js)

        def tracking(ax, j):
            ax.plot(t, num(js, "q_ref_rad." + j), "k--", lw=1, label="q_ref")
            ax.plot(t, num(js, "q_rad." + j), lw=1, label="q")

        save(joint_figure("Joint tracking: q (measured) and q_ref (rad)", tracking), out,
             "joint_tracking.png", made)

    jt = channel(out, prefix, "JOINT_TORQUE", "torque figure")
    if jt:
        t = time_s(jt)

        def torques(ax, j):
            ax.plot(t, num(jt, "tau_command_Nm." + j), lw=1, label="commanded")
            if js:
                ax.plot(time_s(js), num(js, "tau_measured_Nm." + j), lw=1, alpha=0.7,
                        label="measured")

        save(joint_figure("Joint torques (N.m): commanded and measured", torques), out,
             "joint_torques.png", made)

    tm = channel(out, prefix, "TIMING", "timing histogram")
    if tm:
        fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.5))
        total = [v * 1e-3 for v in num(tm, "total_ns")]
        wake = [v * 1e-3 for v in num(tm, "wakeup_latency_ns")]
        a.hist(total, bins=50)
        a.set_xlabel("cycle work, read start to write end (µs)")
        a.set_ylabel("cycles")
        a.set_title("work time: max %.1f µs, %d deadline misses"
                    % (max(total), int(num(tm, "deadline_misses")[-1])))
        b.hist(wake, bins=50, color="tab:orange")
        b.set_xlabel("wake-up latency (µs)")
        b.set_title("wake-up latency: max %.1f µs" % max(wake))
        for ax in (a, b):
            ax.set_yscale("log")
        save(fig, out, "timing_histogram.png", made)

    ev = channel(out, prefix, "EVENT", "events timeline")
    if ev:
        fig, ax = plt.subplots(figsize=(12, 4.5))
        t = time_s(ev)
        to = [int(v) for v in ev["to_mode"]]
        ax.step(t, to, where="post", color="tab:blue", lw=1.5, label="mode after event")
        ax.scatter(t, to, color="tab:red", zorder=3)
        for x, y, r, d in zip(t, to, ev["reason"], ev["detail"]):
            ax.annotate(r if not d else "%s: %s" % (r, d[:40]), (x, y), fontsize=7, rotation=20,
                        xytext=(4, 6), textcoords="offset points")
        ax.set_yticks(range(len(MODES)))
        ax.set_yticklabels(MODES)
        ax.set_xlabel("time since first event (s)")
        ax.set_title("Safety events (%d)" % len(t))
        ax.set_ylim(-0.5, len(MODES) - 0.5)
        save(fig, out, "events_timeline.png", made)

    print("plot: wrote %s in %s" % (", ".join(made) if made else "nothing", out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
