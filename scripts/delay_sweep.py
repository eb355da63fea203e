#!/usr/bin/python3
"""Sweeps the loop's delay through the loop: the shipped configuration's trot on the lag plant and
on the realistic plant with 0, 1, 2, ... cycles of delay added to the plant's own (hyq-sim
--delay-cycles K on the lag plant, K + 1 on the realistic one), and reports for each the mean
tracking error, the largest joint speed over ACTIVE and whether the run stopped under control.
The measured delay margin (the largest extra delay every run survives) is what
tools/hyq-loop-model predicts (docs/tuning.md puts the two side by side).

    /usr/bin/python3 scripts/delay_sweep.py [--out DIR] [--extra 0,1,2] [--plants lag,realistic]
                                            [--duration S] [--reference trot|steer|eight]
                                            [--controller two_stage] [--seed N] [--config FILE]
                                            [--max-peak 10] [--require-extra K] [--build DIR]

--require-extra K: exit 1 unless every run with at most K extra cycles walked (exit 0, no fault,
no fall, stopped) with its peak joint speed at most --max-peak rad/s (the tuning rule's check).
Writes DIR/delay_sweep.json and DIR/delay_sweep.md (the table), and prints the table.
"""
import argparse, json, os, sys, time

import hyq_runs

PLANTS = {  # name -> (hyq-sim arguments without the delay, the plant's own delay in cycles)
    "lag": ([], 0),
    "realistic": (["--profile", "realistic", "--link-errors", "{seed}", "--bias-seed", "{seed}"], 1),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--out", default="delay-sweep", help="output folder (default: delay-sweep)")
    ap.add_argument("--extra", default="0,1,2", help="extra cycles of delay, comma-separated (default 0,1,2)")
    ap.add_argument("--plants", default="lag,realistic", help="lag and/or realistic (default both)")
    ap.add_argument("--duration", type=float, default=10.0, help="reference seconds per run (default 10)")
    ap.add_argument("--reference", default="trot", choices=sorted(hyq_runs.REFERENCES))
    ap.add_argument("--controller", default="two_stage", choices=hyq_runs.CONTROLLERS + ["stage1"])
    ap.add_argument("--seed", type=int, default=1, help="hyq-sim seed (default 1)")
    ap.add_argument("--config", help="the daemon's configuration (default: the shipped simulation one)")
    ap.add_argument("--max-peak", type=float, default=10.0, help="rad/s (default 10)")
    ap.add_argument("--require-extra", type=int, help="exit 1 unless every run up to this many extra cycles walked")
    ap.add_argument("--build", default=hyq_runs.DEFAULT_BUILD, help="build tree (default build/ci)")
    a = ap.parse_args()
    try:
        extras = [int(x) for x in a.extra.split(",") if x]
    except ValueError:
        ap.error(f"--extra: expected comma-separated whole numbers of cycles, found '{a.extra}'")
    if not extras or min(extras) < 0 or max(extras) > 40:
        ap.error(f"--extra: expected cycles in 0..40, found '{a.extra}'")
    plants = [p for p in a.plants.split(",") if p]
    for p in plants:
        if p not in PLANTS:
            ap.error(f"--plants: expected lag or realistic, found '{p}'")
    if not 1.0 <= a.duration <= 3600.0:
        ap.error(f"--duration: expected 1..3600 s, found {a.duration}")
    if a.config and not os.path.isfile(a.config):
        ap.error(f"--config: {a.config}: no such file")
    hyq_runs.require_tools(a.build, ["hyq-sim", "hyq-servod"], "delay_sweep.py")
    os.makedirs(a.out, exist_ok=True)
    rows, t0 = [], time.time()
    total = len(plants) * len(extras)
    for plant in plants:
        args, own = PLANTS[plant]
        for k in extras:
            sim = [x.replace("{seed}", str(a.seed)) for x in args] + ["--delay-cycles", str(own + k),
                                                                      "--seed", str(a.seed)]
            d = os.path.join(a.out, f"{plant}+{k}")
            r = hyq_runs.run(d, a.controller, build=a.build, reference=hyq_runs.REFERENCES[a.reference],
                             steer=hyq_runs.STEER if a.reference == "steer" else (), mu=0.1,
                             duration_s=a.duration, sim_args=sim,
                             servod_config=os.path.abspath(a.config) if a.config else None, retries=1)
            v = hyq_runs.judge(r)
            walked = v["stable"] and v.get("peak_rad_s", float("inf")) <= a.max_peak
            rows.append({"plant": plant, "extra_cycles": k, "delay_cycles": own + k, "walked": walked, **v})
            print(f"[{len(rows)}/{total}, {time.time() - t0:.0f} s] {plant} +{k}: "
                  + (f"error {v['error']:.4f} rad, peak {v['peak_rad_s']:.1f} rad/s ({v['peak_joint']})"
                     if "error" in v else "no summary")
                  + ("" if walked else f"  NOT WALKED: {v.get('why', 'peak above ' + str(a.max_peak))}"),
                  flush=True)
    md = [f"| plant | extra cycles (hyq-sim --delay-cycles) | mean error, rad | peak joint speed, rad/s | walked |",
          "|---|---|---|---|---|"]
    for r in rows:
        err = f"{r['error']:.4f}" if "error" in r else "-"
        peak = f"{r['peak_rad_s']:.1f} ({r['peak_joint']})" if "peak_rad_s" in r else "-"
        md.append(f"| {r['plant']} | +{r['extra_cycles']} ({r['delay_cycles']}) | {err} | {peak} | "
                  + ("yes" if r["walked"] else "**no**: " + str(r.get("why", f"peak above {a.max_peak:g}"))) + " |")
    margins = {}
    for plant in plants:
        ok = [r["extra_cycles"] for r in rows if r["plant"] == plant]
        m = -1
        for k in sorted(ok):
            if all(r["walked"] for r in rows if r["plant"] == plant and r["extra_cycles"] <= k):
                m = k
        margins[plant] = m
    json.dump({"reference": a.reference, "controller": a.controller, "duration_s": a.duration,
               "seed": a.seed, "max_peak_rad_s": a.max_peak, "runs": rows, "walked_up_to": margins},
              open(os.path.join(a.out, "delay_sweep.json"), "w"), indent=1)
    open(os.path.join(a.out, "delay_sweep.md"), "w").write("\n".join(md) + "\n")
    print("\n".join(md))
    print("walked up to: " + ", ".join(f"{p} +{m}" if m >= 0 else f"{p} none" for p, m in margins.items()))
    if a.require_extra is not None:
        short = [p for p, m in margins.items() if m < a.require_extra]
        if short:
            print(f"delay_sweep.py: FAIL: {', '.join(short)} did not walk with {a.require_extra} extra cycles",
                  file=sys.stderr)
            sys.exit(1)


if __name__ == "__main__":
    main()
