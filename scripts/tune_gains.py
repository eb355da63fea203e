#!/usr/bin/python3
"""Tunes every controller's feedback gains the same way (docs/tuning.md), through the loop.

    /usr/bin/python3 scripts/tune_gains.py [--out DIR] [--budget N] [--controllers LIST]
                                           [--sim-arg ARG]... [--write-config] [--build DIR]

The procedure, identical for each controller:
  - the tuning scenario: scripts/hil.sh (through scripts/hyq_runs.py), lock-step, trot on
    mu = 0.1, 5 s, hyq-sim seed 1 (plus whatever --sim-arg adds, e.g. a plant profile), the
    daemon with the shipped simulation configuration and only the candidate's gains changed;
  - the search: N candidates per controller (default 16), the first the untuned gains the project
    shipped before (kp 300 N m/rad, kd 8 N m s/rad, no integral), the others a Halton sequence
    (bases 2, 3, 5) over the controller's own box, log-uniform:
        pid         kp [100, 3000] N m/rad, kd [2, 60] N m s/rad, ki [30, 3000] N m/(rad s)
                    (integral clamped to +-I_LIMIT N m, conditional integration: anti-windup)
        pd_gravity  kp, kd in the same box (feed-forward tau_g, servo/control/pd_gravity.h)
        noslip,     kp_tau, kd_tau in the same box (the PD torque added to the ID's feed-forward;
        two_stage   no acceleration feedback)
    one value for all twelve joints;
  - stable: the daemon stopped under control (exit 0, no fault event) and the robot did not fall;
  - chosen: the stable candidate with the lowest mean tracking error (servod.json,
    tracking_error_mean_rad, over the whole ACTIVE time: stand-up, trot, sit-down) that keeps a
    gain margin: the same run with all its gains x MARGIN is stable too (otherwise the next best;
    the lowest-error stable candidate alone sat on the edge of instability: kp 1036, kd 10.3 for
    the two-stage ID tracked best in place and faulted on a knee speed of 15 rad/s walking at
    0.3 m/s).
Writes DIR/tuning.json (every candidate and its result), DIR/tuning.md (the table) and, with
--write-config, the chosen gains into config/hyq_servo_sim.yaml and config/hyq_servo.yaml.
"""
import argparse, json, math, os, re, time

import hyq_runs

HERE = hyq_runs.HERE
SCENARIO = {"reference": "trot", "mu": 0.1, "duration_s": 5.0, "seed": 1}
I_LIMIT = 100.0                      # N m: two thirds of the joints' 150 N m effort limit
MARGIN = 1.5                         # gain margin the chosen candidate keeps
BOX = {"kp": (100.0, 3000.0), "kd": (2.0, 60.0), "ki": (30.0, 3000.0)}
UNTUNED = {"kp": 300.0, "kd": 8.0, "ki": 0.0}
PARAMS = {"pid": ["kp", "kd", "ki"], "pd_gravity": ["kp", "kd"], "noslip": ["kp", "kd"],
          "two_stage": ["kp", "kd"]}  # the gains searched, for each of hyq_runs.CONTROLLERS
KEYS = {  # controller -> {param: config key under controller.gains}
    "pid": {"kp": "pid_kp", "kd": "pid_kd", "ki": "pid_ki"},
    "pd_gravity": {"kp": "pdg_kp", "kd": "pdg_kd"},
    "noslip": {"kp": "kp_tau", "kd": "kd_tau"},
    "two_stage": {"kp": "kp_tau", "kd": "kd_tau"},
}


def halton(i, base):
    f, r = 1.0, 0.0
    while i > 0:
        f /= base
        r += f * (i % base)
        i //= base
    return r


def candidates(ctrl, budget):
    """The untuned gains first, then Halton points (log-uniform) in the controller's box."""
    out = [{p: UNTUNED[p] for p in PARAMS[ctrl]}]
    for i in range(1, budget):
        c = {}
        for p, base in zip(PARAMS[ctrl], (2, 3, 5)):
            lo, hi = BOX[p]
            c[p] = round(math.exp(math.log(lo) + halton(i, base) * (math.log(hi) - math.log(lo))), 1)
        out.append(c)
    return out


def gains_yaml(ctrl, g):
    """The controller.gains section for one candidate (the other controllers' keys untouched)."""
    lines = ["controller:", "  gains:"]
    for p, key in KEYS[ctrl].items():
        lines.append(f"    {key}: {g[p]}")
    if ctrl == "pid":
        lines.append(f"    pid_i_limit: {I_LIMIT if g['ki'] > 0 else 0}")
    return "\n".join(lines) + "\n"


def shipped_sim_config(build_dir, extra):
    """config/hyq_servo_sim.yaml with absolute paths, plus `extra` (a YAML fragment whose top-level
    keys replace the file's: the candidate's controller section keeps the file's other keys by
    merging below)."""
    src = open(os.path.join(HERE, "config", "hyq_servo_sim.yaml")).read()
    src = re.sub(r"^  urdf: .*$", f"  urdf: {HERE}/config/robots/hyq.urdf", src, flags=re.M)
    src = re.sub(r"^  hal: .*$", f"  hal: {HERE}/config/hyq_hal.yaml", src, flags=re.M)
    return merge_gains(src, extra)


def merge_gains(text, fragment):
    """Replaces (or adds) the keys of `fragment`'s controller.gains in `text`'s controller.gains."""
    keys = dict(re.findall(r"^    (\w+): (.*)$", fragment, flags=re.M))
    lines = text.split("\n")
    try:
        c = next(i for i, l in enumerate(lines) if l.startswith("controller:"))
        g = next(i for i in range(c + 1, len(lines)) if lines[i].startswith("  gains:"))
    except StopIteration:
        raise SystemExit("tune_gains.py: config has no controller.gains section")
    end = g + 1
    while end < len(lines) and lines[end].startswith("    "):
        end += 1
    seen = set()
    for i in range(g + 1, end):
        m = re.match(r"^(    (\w+):\s*.*?)(\s+#.*)?$", lines[i])
        if m and m.group(2) in keys:
            new = f"    {m.group(2)}: {keys[m.group(2)]}"
            if m.group(3):  # the comment stays in its column
                comment = m.group(3).lstrip()
                col = len(lines[i]) - len(comment)
                new = new.ljust(col - 1) + " " + comment
            lines[i] = new
            seen.add(m.group(2))
    for k, v in keys.items():
        if k not in seen:
            lines.insert(end, f"    {k}: {v}")
            end += 1
    return "\n".join(lines)


def evaluate(a, ctrl, g, name):
    """One run of the tuning scenario with gains g, in DIR/runs/NAME."""
    d = os.path.join(a.out, "runs", name)
    os.makedirs(d, exist_ok=True)
    cfg = os.path.join(d, "servo.yaml")
    with open(cfg, "w") as f:
        f.write(shipped_sim_config(a.build, gains_yaml(ctrl, g)))
    r = hyq_runs.run(d, ctrl, build=a.build, reference=SCENARIO["reference"], mu=SCENARIO["mu"],
                     duration_s=SCENARIO["duration_s"], servod_config=cfg,
                     sim_args=["--seed", str(SCENARIO["seed"])] + a.sim_arg)
    return hyq_runs.judge(r)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--out", default="tuning", help="output folder (default: tuning)")
    ap.add_argument("--budget", type=int, default=16, help="candidates per controller (default 16)")
    ap.add_argument("--controllers", default=",".join(hyq_runs.CONTROLLERS),
                    help=f"comma-separated (default: {','.join(hyq_runs.CONTROLLERS)})")
    ap.add_argument("--sim-arg", action="append", default=[], help="passed to hyq-sim (repeatable)")
    ap.add_argument("--write-config", action="store_true",
                    help="write the chosen gains into config/hyq_servo_sim.yaml and config/hyq_servo.yaml")
    ap.add_argument("--build", default=hyq_runs.DEFAULT_BUILD, help="build tree (default build/ci)")
    a = ap.parse_args()
    ctrls = [c for c in a.controllers.split(",") if c]
    for c in ctrls:
        if c not in hyq_runs.CONTROLLERS:
            ap.error(f"--controllers: '{c}' is not one of {', '.join(hyq_runs.CONTROLLERS)}")
    if a.budget < 1 or a.budget > 256:
        ap.error(f"--budget: expected 1..256, found {a.budget}")
    hyq_runs.require_tools(a.build, ["hyq-sim", "hyq-servod"], "tune_gains.py")
    os.makedirs(a.out, exist_ok=True)
    results = {"scenario": {**SCENARIO, "sim_args": a.sim_arg}, "budget": a.budget, "i_limit_Nm": I_LIMIT,
               "box": BOX, "controllers": {}}
    total, done, t0 = a.budget * len(ctrls), 0, time.time()
    for ctrl in ctrls:
        rows = []
        for k, g in enumerate(candidates(ctrl, a.budget)):
            r = evaluate(a, ctrl, g, f"{ctrl}_{k:02d}")
            rows.append({"gains": g, **r})
            done += 1
            eta = (time.time() - t0) / done * (total - done)
            err = f"{r['error']:.4f} rad" if "error" in r else "-"
            print(f"[{done}/{total}, ~{eta:.0f} s left] {ctrl} {g}: {err}"
                  f"{'' if r['stable'] else '  UNSTABLE: ' + r.get('why', '')}", flush=True)
        best = None
        for k, r in enumerate(sorted([r for r in rows if r["stable"]], key=lambda r: r["error"])):
            g = {p: round(v * MARGIN, 1) for p, v in r["gains"].items()}
            m = evaluate(a, ctrl, g, f"{ctrl}_margin_{k:02d}")
            r["margin"] = {"gains": g, **m}
            print(f"  {ctrl} {r['gains']} x{MARGIN}: " + ("stable" if m["stable"] else "UNSTABLE: " + m.get("why", "")), flush=True)
            if m["stable"]:
                best = r
                break
        results["controllers"][ctrl] = {"candidates": rows, "chosen": best, "untuned": rows[0]}
    json.dump(results, open(os.path.join(a.out, "tuning.json"), "w"), indent=1)
    md = [f"| controller | untuned (kp 300, kd 8) error, rad | chosen gains | chosen error, rad | stable candidates | lower-error candidates without the x{MARGIN} margin |",
          "|---|---|---|---|---|---|"]
    for ctrl, c in results["controllers"].items():
        u, b = c["untuned"], c["chosen"]
        ue = f"{u['error']:.4f}" if u.get("stable") else "unstable"
        bg = ", ".join(f"{k} {v:g}" for k, v in b["gains"].items()) if b else "none stable"
        be = f"{b['error']:.4f}" if b else "-"
        lost = [r for r in c["candidates"] if "margin" in r and not r["margin"]["stable"]]
        lost_txt = "; ".join(", ".join(f"{k} {v:g}" for k, v in r["gains"].items()) + f" ({r['error']:.4f})" for r in lost) or "none"
        md.append(f"| {ctrl} | {ue} | {bg} | {be} | {sum(r['stable'] for r in c['candidates'])}/{len(c['candidates'])} | {lost_txt} |")
    open(os.path.join(a.out, "tuning.md"), "w").write("\n".join(md) + "\n")
    print("\n".join(md))
    if a.write_config:
        for name in ("hyq_servo_sim.yaml", "hyq_servo.yaml"):
            p = os.path.join(HERE, "config", name)
            text = open(p).read()
            for ctrl, c in results["controllers"].items():
                # the ID kinds share kp_tau / kd_tau in the file: two_stage's choice is written;
                # noslip's own is in tuning.json (hil_experiments.py runs it with it)
                if c["chosen"] and not (ctrl == "noslip" and "two_stage" in results["controllers"]):
                    text = merge_gains(text, gains_yaml(ctrl, c["chosen"]["gains"]))
            open(p, "w").write(text)
            print(f"tune_gains.py: wrote the chosen gains into {p}")


if __name__ == "__main__":
    main()
