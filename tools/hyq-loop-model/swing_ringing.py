#!/usr/bin/python3
"""The swing legs' ringing in a hyq-sim truth file, beside hyq-loop-model's prediction.

usage: swing_ringing.py TRUTH.csv [--from S] [--to S]

TRUTH.csv: hyq-sim --truth with --truth-every 1 (scripts/hil.sh --sim-arg --truth-every
--sim-arg 1 keeps it as OUT/truth.csv). Per HFE and KFE joint, over the swings between --from and
--to (default 3 s to the end; a swing: the foot's normal force below 1 N for at least 100 ms):
the joint angle minus a degree-8 polynomial fitted over the swing (the reference's own motion
is smoother than that; what is left is the ringing above ~10 Hz), its RMS, its largest value and
the frequency of its largest spectral peak (median over the swings). Then, if some joint speed
passes 5 rad/s, the 50 ms windows before the fastest moment: the ringing's amplitude (peak |q̇|
above 20 Hz), so that its growth rate can be read against the model's root (ln|z| / T).
"""
import argparse
import sys

import numpy as np
from scipy import signal

JOINTS = [leg + "_" + j for j in ("hfe", "kfe") for leg in ("lf", "rf", "lh", "rh")]


def swings(t, fz, t0, t1):
    air = signal.medfilt((fz < 1.0).astype(float), 31) > 0.5
    edges = np.flatnonzero(np.diff(air.astype(int)))
    for a, b in zip(edges[:-1], edges[1:]):
        if air[a + 1] and t[a] >= t0 and t[b] <= t1 and b - a > 100:
            yield slice(a + 20, b - 20)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("truth")
    p.add_argument("--from", dest="t0", type=float, default=3.0)
    p.add_argument("--to", dest="t1", type=float, default=1e9)
    a = p.parse_args()
    d = np.genfromtxt(a.truth, delimiter=",", names=True)
    t = d["t"]
    if len(t) < 2 or t[1] - t[0] > 1.5e-3:
        sys.exit("swing_ringing.py: expected one truth row per 1 ms step (--truth-every 1)")
    print("| joint | swings | residual RMS (mrad) | largest (mrad) | peak (Hz) |")
    print("|---|---|---|---|---|")
    for j in JOINTS:
        q = d["q_%s_joint" % j]
        rows = []
        for s in swings(t, d[j[:2] + "_fz"], a.t0, a.t1):
            tt = t[s] - t[s].mean()
            r = q[s] - np.polyval(np.polyfit(tt, q[s], 8), tt)
            f, P = signal.periodogram(r, fs=1000, nfft=4096)
            band = (f > 4) & (f < 200)
            rows.append((r.std() * 1e3, np.abs(r).max() * 1e3, f[band][np.argmax(P[band])]))
        if not rows:
            continue
        r = np.array(rows)
        print("| %s | %d | %.2f | %.2f | %.1f |" % (j, len(r), r[:, 0].mean(), r[:, 1].max(), np.median(r[:, 2])))
    qd = {j: d["qd_%s_joint" % j] for j in JOINTS}
    fastest = max(JOINTS, key=lambda j: np.abs(qd[j]).max())
    if np.abs(qd[fastest]).max() < 5.0:
        return
    i_max = int(np.argmax(np.abs(qd[fastest])))
    hp = signal.filtfilt(*signal.butter(4, 20.0, "highpass", fs=1000), qd[fastest])
    print("\n%s reaches %.1f rad/s at %.3f s; the ringing before it (q̇ above 20 Hz):" %
          (fastest, np.abs(qd[fastest]).max(), t[i_max]))
    for k in range(6, 0, -1):
        w = slice(max(0, i_max - 50 * k), i_max - 50 * (k - 1))
        f, P = signal.periodogram(hp[w], fs=1000, nfft=2048)
        band = (f > 20) & (f < 200)
        print("  %.3f-%.3f s: peak |q̇| %.2f rad/s, at %.0f Hz" %
              (t[w][0], t[w][-1], np.abs(hp[w]).max(), f[band][np.argmax(P[band])]))


if __name__ == "__main__":
    main()
