#!/usr/bin/python3
"""Tunes every controller's feedback gains the same way (docs/tuning.md), through the loop, with
delay in the loop.

    /usr/bin/python3 scripts/tune_gains.py [--out DIR] [--budget N] [--controllers LIST]
                                           [--seeds 1,2,3] [--duration S] [--write-config]
                                           [--build DIR] [--quick]

The rule, identical for each controller:
  - a candidate counts only if it walks, through the loop (scripts/hil.sh through
    scripts/hyq_runs.py, lock-step, mu = 0.1, DURATION s of reference, default 20), the trot, the
    steered trot (hyq_runs.STEER) and the Figure-Eight, hyq-sim seeds 1-3, on the lag plant with
    two cycles of delay added (hyq-sim --delay-cycles 2) and on the realistic plant with two
    added to its own one (--profile realistic --delay-cycles 3): no fault, no fall, the daemon
    stopped under control, and the largest joint speed over ACTIVE (servod.json,
    joint_speed_max_rad_s) at most PEAK_LIMIT = 10 rad/s, against the safety's 15;
  - and keeps a gain margin on the nominal plant (the lag plant, no delay added): the trot with
    all its feedback gains x MARGIN = 1.5 walks too, with the same peak limit;
  - chosen: of those, the lowest mean tracking error over the delayed runs (servod.json's
    tracking_error_mean_rad, over the whole ACTIVE time: stand-up, reference, sit-down);
  - the search, per controller, N candidates (default 24): the first the start point (START),
    the others a Latin hypercube over the controller's box, log-uniform, per joint type (HAA,
    HFE, KFE):
        kp        [100, 1200] N m/rad        kd  [2, 30] N m s/rad  (per joint type)
        swing     [0.2, 1]                   the gains on a swing leg's joints x this
        pid ki    [0, 0] or [30, 1000] N m/(rad s) (integral clamped to +-I_LIMIT: anti-windup)
        IDs kd_acc [20, 80] 1/s, kp_acc = kd_acc^2 / 4 (critically damped): the stance legs'
                  feedback through the ID's model, in the desired accelerations
    The runs of a candidate go hardest first (the realistic plant's trot) and stop at its first
    failure, so an unstable candidate costs a run or two.
Writes DIR/tuning.json (every candidate and every run's verdict), DIR/tuning.md (the table)
and, with --write-config, the chosen gains into config/hyq_servo_sim.yaml and
config/hyq_servo.yaml (the IDs share kp_tau, kd_tau: the two-stage ID's are written; the
no-slip ID's are in tuning.json, which scripts/hil_experiments.py reads). --quick: one seed and
the trot only (a screening, not the rule).
"""
import argparse, json, math, os, random, re, time

import hyq_runs

HERE = hyq_runs.HERE
MU = 0.1
I_LIMIT = 100.0                      # N m: two thirds of the joints' 150 N m effort limit
MARGIN = 1.5                         # gain margin the chosen candidate keeps on the nominal plant
PEAK_LIMIT = 10.0                    # rad/s, the largest joint speed a counted run may reach
DELAYED = {                          # the plants with two cycles of delay added
    "lag+2": ["--delay-cycles", "2"],
    "realistic+2": ["--profile", "realistic", "--link-errors", "{seed}", "--bias-seed", "{seed}",
                    "--delay-cycles", "3"],
}
MANEUVERS = ["trot", "steer", "eight"]
BOX = {"kp": (100.0, 1200.0), "kd": (2.0, 30.0), "swing": (0.2, 1.0), "ki": (30.0, 1000.0),
       "kd_acc": (20.0, 80.0)}
JOINT_TYPES = ["haa", "hfe", "kfe"]
# the start points: the IDs' shipped feedback, the PID and PD + g on the same PD
START = {
    "two_stage": {"kp": [300.0] * 3, "kd": [8.0] * 3, "swing": 0.5, "kd_acc": 40.0},
    "noslip": {"kp": [300.0] * 3, "kd": [8.0] * 3, "swing": 0.5, "kd_acc": 40.0},
    "pid": {"kp": [300.0] * 3, "kd": [8.0] * 3, "swing": 0.5, "ki": 0.0},
    "pd_gravity": {"kp": [300.0] * 3, "kd": [8.0] * 3, "swing": 0.5},
}
KEYS = {  # controller -> (kp key, kd key, swing key) under controller.gains
    "pid": ("pid_kp", "pid_kd", "pid_swing_scale"),
    "pd_gravity": ("pdg_kp", "pdg_kd", "pdg_swing_scale"),
    "noslip": ("kp_tau", "kd_tau", "swing_scale"),
    "two_stage": ("kp_tau", "kd_tau", "swing_scale"),
}
def log_in(lo, hi, u):
    return math.exp(math.log(lo) + u * (math.log(hi) - math.log(lo)))


def candidates(ctrl, budget):
    """The start point, then a Latin hypercube (log-uniform) in the controller's box: each
    parameter's range cut into budget - 1 strata, one point in each, the strata shuffled per
    parameter (seeded by the controller's name: the same candidates every run)."""
    out = [json.loads(json.dumps(START[ctrl]))]
    n = budget - 1
    if n < 1:
        return out
    rng = random.Random(ctrl)
    dims = ["kp"] * 3 + ["kd"] * 3 + ["swing"] + (["ki"] if ctrl == "pid" else []) + \
           (["kd_acc"] if ctrl in ("two_stage", "noslip") else [])
    cols = []
    for _ in dims:
        strata = list(range(n))
        rng.shuffle(strata)
        cols.append([(k + rng.random()) / n for k in strata])
    for i in range(n):
        u = {d: [] for d in dims}
        for d, col in zip(dims, cols):
            u[d].append(col[i])
        c = {"kp": [round(log_in(*BOX["kp"], x), 1) for x in u["kp"]],
             "kd": [round(log_in(*BOX["kd"], x), 2) for x in u["kd"]],
             "swing": round(log_in(*BOX["swing"], u["swing"][0]), 3)}
        if ctrl == "pid":  # a third of the candidates without integral action
            x = u["ki"][0]
            c["ki"] = 0.0 if x < 1 / 3 else round(log_in(*BOX["ki"], (x - 1 / 3) * 1.5), 1)
        if ctrl in ("two_stage", "noslip"):
            c["kd_acc"] = round(log_in(*BOX["kd_acc"], u["kd_acc"][0]), 1)
        out.append(c)
    return out


def scaled(g, factor):
    """The candidate with its feedback gains x factor (the swing scale is a ratio: unchanged)."""
    s = dict(g, kp=[round(v * factor, 1) for v in g["kp"]], kd=[round(v * factor, 2) for v in g["kd"]])
    if "ki" in g:
        s["ki"] = round(g["ki"] * factor, 1)
    if "kd_acc" in g:
        s["kd_acc"] = round(g["kd_acc"] * factor, 1)
    return s


def gains_yaml(ctrl, g):
    """The controller.gains keys of one candidate (the other controllers' keys untouched)."""
    kp, kd, sw = KEYS[ctrl]
    lines = ["controller:", "  gains:",
             f"    {kp}: [{', '.join(f'{v:g}' for v in g['kp'])}]",
             f"    {kd}: [{', '.join(f'{v:g}' for v in g['kd'])}]",
             f"    {sw}: {g['swing']:g}"]
    if ctrl == "pid":
        lines += [f"    pid_ki: {g['ki']:g}", f"    pid_i_limit: {I_LIMIT if g['ki'] > 0 else 0:g}"]
    if "kd_acc" in g:
        lines += [f"    kp_acc: {g['kd_acc'] ** 2 / 4:g}", f"    kd_acc: {g['kd_acc']:g}"]
    return "\n".join(lines) + "\n"


def shipped_sim_config(build_dir, extra):
    """config/hyq_servo_sim.yaml with absolute paths and the gains of `extra` merged in (the
    build tree does not change it: the signature scripts/baseline_experiments.py calls)."""
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
    while end < len(lines) and (lines[end].startswith("    ") or not lines[end].strip()):
        end += 1
    while not lines[end - 1].strip():
        end -= 1
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


def scenarios(seeds, quick):
    """(plant, maneuver, seed) in the order they are run: hardest first."""
    if quick:
        return [(p, "trot", seeds[0]) for p in ("realistic+2", "lag+2")]
    return [(p, m, s) for s in seeds for m in MANEUVERS for p in ("realistic+2", "lag+2")]


class Tuner:
    def __init__(self, a):
        self.a, self.runs = a, 0

    def run(self, ctrl, g, name, plant_args, reference, seed):
        d = os.path.join(self.a.out, "runs", name)
        os.makedirs(d, exist_ok=True)
        cfg = os.path.join(d, "servo.yaml")
        with open(cfg, "w") as f:
            f.write(shipped_sim_config(self.a.build, gains_yaml(ctrl, g)))
        sim = [x.replace("{seed}", str(seed)) for x in plant_args] + ["--seed", str(seed)]
        r = hyq_runs.run(d, ctrl, build=self.a.build, reference=hyq_runs.REFERENCES[reference],
                         steer=hyq_runs.STEER if reference == "steer" else (), mu=MU,
                         duration_s=self.a.duration, servod_config=cfg, sim_args=sim, retries=1,
                         reuse=True)
        self.runs += 1
        v = hyq_runs.judge(r)
        if v["stable"] and not v["peak_rad_s"] <= PEAK_LIMIT:
            v["stable"] = False
            v["why"] = f"peak {v['peak_rad_s']:.1f} rad/s on {v['peak_joint']} above {PEAK_LIMIT:g}"
        return v

    def evaluate(self, ctrl, k, g):
        """The rule for one candidate: its verdict, the runs' verdicts (up to the first failure)."""
        runs = []
        for plant, man, seed in scenarios(self.a.seeds, self.a.quick):
            v = self.run(ctrl, g, f"{ctrl}_{k:02d}_{plant}_{man}_s{seed}", DELAYED[plant], man, seed)
            runs.append({"plant": plant, "maneuver": man, "seed": seed, **v})
            if not v["stable"]:
                return {"counts": False, "why": f"{plant} {man} seed {seed}: {v.get('why')}", "runs": runs}
        m = self.run(ctrl, scaled(g, MARGIN), f"{ctrl}_{k:02d}_margin", [], "trot", 1)
        if not m["stable"]:
            return {"counts": False, "why": f"gains x{MARGIN} on the nominal trot: {m.get('why')}",
                    "runs": runs, "margin": m}
        errors = [r["error"] for r in runs]
        peaks = [r["peak_rad_s"] for r in runs]
        return {"counts": True, "error": sum(errors) / len(errors), "peak_rad_s": max(peaks),
                "runs": runs, "margin": m}


def shipped_gains(ctrl):
    """The gains config/hyq_servo_sim.yaml ships for `ctrl`, as a candidate."""
    import yaml
    g = yaml.safe_load(open(os.path.join(HERE, "config", "hyq_servo_sim.yaml")))["controller"]["gains"]
    kp, kd, sw = KEYS[ctrl]
    three = lambda v: [float(x) for x in v] if isinstance(v, list) else [float(v)] * 3
    c = {"kp": three(g.get(kp, 0.0)), "kd": three(g.get(kd, 0.0)), "swing": float(g.get(sw, 1.0))}
    if ctrl == "pid":
        c["ki"] = float(g.get("pid_ki", 0.0))
    if ctrl in ("two_stage", "noslip") and float(g.get("kd_acc", 0.0)) > 0:
        c["kd_acc"] = float(g["kd_acc"])
    return c


def check(a, tuner, ctrls):
    """The rule on the shipped gains: DIR/check.json; exit 1 when one controller's fail it."""
    out, bad = {}, []
    for ctrl in ctrls:
        g = shipped_gains(ctrl)
        r = tuner.evaluate(ctrl, 99, g)
        out[ctrl] = {"gains": g, **r}
        print(f"{ctrl} {describe(g)}: " + (f"counts: error {r['error']:.4f} rad, peak {r['peak_rad_s']:.1f} rad/s"
                                           if r["counts"] else f"does not count: {r['why']}"), flush=True)
        if not r["counts"]:
            bad.append(ctrl)
    json.dump(out, open(os.path.join(a.out, "check.json"), "w"), indent=1)
    print(f"tune_gains.py: {tuner.runs} runs; {a.out}/check.json")
    return 1 if bad else 0


def describe(g):
    t = (f"kp [{', '.join(f'{v:g}' for v in g['kp'])}], kd [{', '.join(f'{v:g}' for v in g['kd'])}], "
         f"swing {g['swing']:g}")
    if "ki" in g:
        t += f", ki {g['ki']:g}"
    if "kd_acc" in g:
        t += f", kd_acc {g['kd_acc']:g} (kp_acc {g['kd_acc'] ** 2 / 4:g})"
    return t


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--out", default="tuning", help="output folder (default: tuning)")
    ap.add_argument("--budget", type=int, default=24, help="candidates per controller (default 24)")
    ap.add_argument("--controllers", default=",".join(hyq_runs.CONTROLLERS),
                    help=f"comma-separated (default: {','.join(hyq_runs.CONTROLLERS)})")
    ap.add_argument("--seeds", default="1,2,3", help="hyq-sim seeds (default 1,2,3)")
    ap.add_argument("--duration", type=float, default=20.0, help="reference seconds per run (default 20)")
    ap.add_argument("--quick", action="store_true", help="one seed, the trot only: a screening")
    ap.add_argument("--check", action="store_true",
                    help="no search: the rule on the gains config/hyq_servo_sim.yaml ships (exit 1 if they fail it)")
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
    try:
        a.seeds = [int(s) for s in a.seeds.split(",") if s]
    except ValueError:
        ap.error(f"--seeds: expected comma-separated integers, found '{a.seeds}'")
    if not a.seeds:
        ap.error("--seeds: expected at least one seed")
    if not 1.0 <= a.duration <= 600.0:
        ap.error(f"--duration: expected 1..600 s, found {a.duration}")
    hyq_runs.require_tools(a.build, ["hyq-sim", "hyq-servod"], "tune_gains.py")
    os.makedirs(a.out, exist_ok=True)
    tuner = Tuner(a)
    if a.check:
        return check(a, tuner, ctrls)
    results = {"rule": {"mu": MU, "duration_s": a.duration, "seeds": a.seeds, "plants": DELAYED,
                        "maneuvers": MANEUVERS, "steer": hyq_runs.STEER, "peak_limit_rad_s": PEAK_LIMIT,
                        "margin": MARGIN, "quick": a.quick},
               "budget": a.budget, "i_limit_Nm": I_LIMIT, "box": BOX, "controllers": {}}
    total, done, t0 = a.budget * len(ctrls), 0, time.time()
    for ctrl in ctrls:
        rows = []
        for k, g in enumerate(candidates(ctrl, a.budget)):
            r = tuner.evaluate(ctrl, k, g)
            rows.append({"gains": g, **r})
            done += 1
            eta = (time.time() - t0) / done * (total - done)
            verdict = (f"counts: error {r['error']:.4f} rad, peak {r['peak_rad_s']:.1f} rad/s"
                       if r["counts"] else f"out: {r['why']}")
            print(f"[{done}/{total}, {tuner.runs} runs, ~{eta:.0f} s left] {ctrl} {describe(g)}: {verdict}",
                  flush=True)
        counted = sorted([r for r in rows if r["counts"]], key=lambda r: r["error"])
        results["controllers"][ctrl] = {"candidates": rows, "chosen": counted[0] if counted else None}
        json.dump(results, open(os.path.join(a.out, "tuning.json"), "w"), indent=1)
    md = ["| controller | chosen gains | mean error over the delayed runs, rad | largest joint speed, rad/s | candidates that count | why the others do not (first failure) |",
          "|---|---|---|---|---|---|"]
    for ctrl, c in results["controllers"].items():
        b = c["chosen"]
        why = {}
        for r in c["candidates"]:
            if not r["counts"]:
                key = r["why"].split(":")[0]
                why[key] = why.get(key, 0) + 1
        why_txt = "; ".join(f"{k}: {n}" for k, n in sorted(why.items(), key=lambda x: -x[1])) or "-"
        row = (f"| {ctrl} | {describe(b['gains'])} | {b['error']:.4f} | {b['peak_rad_s']:.1f} | " if b
               else f"| {ctrl} | none counts | - | - | ")
        md.append(row + f"{sum(r['counts'] for r in c['candidates'])}/{len(c['candidates'])} | {why_txt} |")
    open(os.path.join(a.out, "tuning.md"), "w").write("\n".join(md) + "\n")
    print("\n".join(md))
    print(f"tune_gains.py: {tuner.runs} runs in {time.time() - t0:.0f} s; {a.out}/tuning.json")
    if a.write_config:
        for name in ("hyq_servo_sim.yaml", "hyq_servo.yaml"):
            p = os.path.join(HERE, "config", name)
            text = open(p).read()
            for ctrl, c in results["controllers"].items():
                if c["chosen"] and not (ctrl == "noslip" and "two_stage" in results["controllers"]):
                    text = merge_gains(text, gains_yaml(ctrl, c["chosen"]["gains"]))
            open(p, "w").write(text)
            print(f"tune_gains.py: wrote the chosen gains into {p}")


if __name__ == "__main__":
    raise SystemExit(main())
