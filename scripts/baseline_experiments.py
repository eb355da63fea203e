#!/usr/bin/python3
"""The baselines through the loop: the four controllers with their own tuned gains on the plant
variants, trot and Figure-Eight, several seeds (docs/baselines.md quotes the output).

    /usr/bin/python3 scripts/baseline_experiments.py [--out DIR] [--tuning FILE] [--seeds 1,2,3]
        [--mu 0.1[,1.0]] [--mu1-variants ideal,realistic] [--variants ideal,...]
        [--controllers LIST] [--quick] [--build DIR] [--all] [--tables-only]

--all regenerates every table and figure of docs/baselines.md with this one command: these
runs, three runs for DIR/delay_evidence.png (why one cycle of delay faults on the lag plant),
then the in-process runs of docs/experiments.md (hyq-experiment --all with the tuned gains and
with --gains untuned, and the paper's scenarios on --profile realistic) into DIR/inprocess*/,
and docs/hil_experiments.md's runs (scripts/hil_experiments.py) into DIR/hil-experiments/.

Each run is scripts/hil.sh (hyq-sim + hyq-servod on the virtual buses, lock-step; through
scripts/hyq_runs.py, which lists the plant variants) with the shipped simulation configuration,
the controller's gains from --tuning (scripts/tune_gains.py's tuning.json: each controller its
own chosen gains) or, without it, the ones in config/hyq_servo_sim.yaml, and hyq-sim's arguments
of the variant plus --seed. Judged as tune_gains.py judges (hyq_runs.judge): the mean tracking
error over ACTIVE (servod.json), a fall while ACTIVE, a fault. Writes
DIR/runs/<variant>_<ref>_mu<mu>_<ctrl>_s<seed>/, DIR/results.json, DIR/tables.md
and DIR/baselines.png. Every number comes from these runs.
"""
import argparse, json, math, os, re, statistics, subprocess, sys, time

import hyq_runs
import tune_gains  # the same configuration writer

HERE = hyq_runs.HERE
DURATION_S = 5.0  # of each reference
CTRLS = hyq_runs.CONTROLLERS
# with the trunk's disturbance observer in the model (controller.disturbance_observer):
# "<controller>+dob", the controller's own tuned gains
DOB = "+dob"
# with integral action in the ID controllers' feedback (controller.gains.ki_tau, i_limit_tau):
# "<controller>+int". KI_TAU from a sweep of {0, 100, 300, 1000, 3000} N m/(rad s) through the loop
# (trot and Figure-Eight, ideal and realistic plant, seed 1; docs/baselines.md): it leaves the trot
# alone and takes 30 % off the Figure-Eight; 1000 is the smallest value that gets most of that.
INT = "+int"
KI_TAU, I_LIMIT_TAU = 1000.0, 100.0
# with lower feedback gains on swing legs (controller.gains.swing_scale for the IDs, pid_swing_scale,
# pdg_swing_scale): "<controller>+swing"; 0.3 brings the tuned kd 28 on a swing leg to the untuned 8
# that held the real-time runs (docs/benchmarks.md). The shipped sim configuration has the IDs'
# 0.3 (so "two_stage+swing" is "two_stage"); "+noswing" sets the controller's scale to 1.0 (off)
SWING = "+swing"
SWING_SCALE = 0.3
NOSWING = "+noswing"
SWING_KEY = {"pid": "pid_swing_scale", "pd_gravity": "pdg_swing_scale"}  # the rest: swing_scale
# the plant variants (hyq_runs.PLANTS: hyq-sim's arguments of each), each run on every seed if
# the seed draws something in it, else once (seed 1)
VARIANTS = ["ideal", "payload", "payload_3kg", "link_errors", "joint_friction", "delay", "biases",
            "hydraulics", "realistic_no_hydraulics", "realistic"]


def base_of(ctrl):
    """'two_stage+dob+int' -> 'two_stage'."""
    return ctrl.split("+")[0]


def chosen_gains(tuning_path):
    if not tuning_path:
        return {}
    t = json.load(open(tuning_path))
    return {c: v["chosen"]["gains"] for c, v in t["controllers"].items() if v.get("chosen")}


def config_for(out_dir, build, ctrl, gains):
    dob, integral, swing, noswing = DOB in ctrl, INT in ctrl, SWING in ctrl, NOSWING in ctrl
    ctrl = base_of(ctrl)
    frag = tune_gains.gains_yaml(ctrl, gains[ctrl]) if ctrl in gains else ""
    text = tune_gains.shipped_sim_config(build, frag) if frag else tune_gains.shipped_sim_config(
        build, "controller:\n  gains:\n")
    if dob:  # the section goes into controller: (after its gains)
        text = text.replace("\ncontroller:\n", "\ncontroller:\n  disturbance_observer:\n    enabled: true\n", 1)
    if integral:
        text = text.replace("\n  gains:\n", f"\n  gains:\n    ki_tau: {KI_TAU}\n    i_limit_tau: {I_LIMIT_TAU}\n", 1)
    if swing or noswing:  # the shipped file's own key, if any, replaced
        key = SWING_KEY.get(ctrl, "swing_scale")
        text = re.sub(rf"\n    {key}:[^\n]*", "", text)
        text = text.replace("\n  gains:\n", f"\n  gains:\n    {key}: {SWING_SCALE if swing else 1.0}\n", 1)
    p = os.path.join(out_dir, "servo.yaml")
    open(p, "w").write(text)
    return p


def short_why(bad):
    """The stops of unstable runs, briefly: the fault reasons, a fall, a missing summary."""
    why = set()
    for x in bad:
        why.update(f for f in x.get("faults", []) if f != "damping_done")
        if x.get("fell"):
            why.add("fell")
        if "error" not in x:
            why.add("no summary")
    return ", ".join(sorted(why)) or f"exit {bad[0]['exit']}"


def fmt(xs):
    xs = [x for x in xs if x is not None and not math.isnan(x)]
    if not xs:
        return "-"
    m = statistics.mean(xs)
    return f"{m:.4f}" + (f" ± {statistics.stdev(xs):.4f}" if len(xs) > 1 else "")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--out", default="baselines", help="output folder (default: baselines)")
    ap.add_argument("--tuning", help="tune_gains.py's tuning.json (default: the gains in the config file)")
    ap.add_argument("--seeds", default="1,2,3", help="hyq-sim seeds (default 1,2,3)")
    ap.add_argument("--mu", default="0.1", help="ground friction, comma-separated (default 0.1)")
    ap.add_argument("--mu1-variants", default="ideal,realistic",
                    help="variants also run on mu = 1.0 (default ideal,realistic; '' for none)")
    ap.add_argument("--all", action="store_true",
                    help="also the in-process experiments and scripts/hil_experiments.py (see above)")
    ap.add_argument("--variants", default=",".join(VARIANTS), help=f"plant variants (default: {','.join(VARIANTS)})")
    ap.add_argument("--controllers", default=",".join(CTRLS), help=f"default: {','.join(CTRLS)}")
    ap.add_argument("--quick", action="store_true", help="seed 1 only, trot only")
    ap.add_argument("--build", default=hyq_runs.DEFAULT_BUILD)
    ap.add_argument("--tables-only", action="store_true",
                    help="no runs: the tables and the figure again from DIR/results.json")
    a = ap.parse_args()
    try:
        seeds = [int(s) for s in a.seeds.split(",")]
        mus = [float(m) for m in a.mu.split(",")]
    except ValueError as e:
        ap.error(f"--seeds / --mu: expected comma-separated numbers ({e})")
    variants = a.variants.split(",")
    mu1 = [v for v in a.mu1_variants.split(",") if v]
    for v in variants + mu1:
        if v not in VARIANTS:
            ap.error(f"--variants / --mu1-variants: '{v}' is not one of {', '.join(VARIANTS)}")
    ctrls = a.controllers.split(",")
    for c in ctrls:
        mods = c.split("+")[1:]
        if base_of(c) not in CTRLS or any(m not in ("dob", "int", "swing", "noswing") for m in mods) or (
                "int" in mods and base_of(c) not in ("noslip", "two_stage")):
            ap.error(f"--controllers: '{c}' is not one of {', '.join(CTRLS)} (each optionally +dob, "
                     "+swing or +noswing; the ID controllers also +int)")
    refs = ["trot"] if a.quick else ["trot", "eight"]  # (the steered trot is the tuning rule's: tune_gains.py)
    if a.quick:
        seeds = seeds[:1]
    gains = chosen_gains(a.tuning)
    os.makedirs(a.out, exist_ok=True)
    def seeds_of(v):
        return seeds if v in hyq_runs.SEEDED_PLANTS else seeds[:1]
    def mus_of(v):
        return mus + ([1.0] if v in mu1 and 1.0 not in mus and not a.quick else [])
    runs = [(v, r, mu, c, s) for v in variants for r in refs for mu in mus_of(v) for c in ctrls for s in seeds_of(v)]
    results, t0 = {"gains": gains, "variants": {v: hyq_runs.PLANTS[v] for v in variants}, "runs": {}}, time.time()
    if a.tables_only:
        results = json.load(open(os.path.join(a.out, "results.json")))
        runs = []
    for k, (v, r, mu, c, s) in enumerate(runs):
        name = f"{v}_{r}_mu{mu}_{c}_s{s}"
        d = os.path.join(a.out, "runs", name)
        os.makedirs(d, exist_ok=True)
        cfg = config_for(d, a.build, c, gains)
        res = hyq_runs.judge(hyq_runs.run(
            d, base_of(c), build=a.build, reference=hyq_runs.REFERENCES[r], mu=mu, duration_s=DURATION_S,
            servod_config=cfg, sim_args=["--seed", str(s)] + hyq_runs.plant_args(v, s)))
        results["runs"][name] = {"variant": v, "ref": r, "mu": mu, "ctrl": c, "seed": s, **res}
        eta = (time.time() - t0) / (k + 1) * (len(runs) - k - 1)
        err = f"{res['error']:.4f} rad" if "error" in res else "-"
        print(f"[{k + 1}/{len(runs)}, ~{eta:.0f} s left] {name}: {err}"
              f"{'' if res['stable'] else '  ' + res.get('why', '')}", flush=True)
    if runs:
        json.dump(results, open(os.path.join(a.out, "results.json"), "w"), indent=1)
    L = []
    for v in variants:
        for mu in mus_of(v):
            L.append(f"\n### {v} plant, mu = {mu} (mean tracking error over ACTIVE, rad: mean ± sd over seeds {','.join(map(str, seeds_of(v)))}; hyq-sim {' '.join(hyq_runs.PLANTS[v]) or 'defaults'})\n")
            L.append("| scenario | " + " | ".join(ctrls) + " | two-stage vs PID | two-stage vs PD + g | two-stage + DOB vs two-stage | two-stage + integral vs two-stage | two-stage vs two-stage without swing gains |")
            L.append("|---|" + "---|" * (len(ctrls) + 5))
            for r in refs:
                cells, means = [], {}
                for c in ctrls:
                    rs = [results["runs"][f"{v}_{r}_mu{mu}_{c}_s{s}"] for s in seeds_of(v)]
                    errs = [x.get("error", float("nan")) for x in rs]
                    bad = [x for x in rs if not x["stable"]]
                    means[c] = statistics.mean([e for e in errs if not math.isnan(e)]) if any(
                        not math.isnan(e) for e in errs) else float("nan")
                    cells.append(fmt(errs) + (f" ({len(bad)} of {len(rs)} unstable: " + short_why(bad) + ")" if bad else ""))
                rel = []
                for a_, b_ in (("two_stage", "pid"), ("two_stage", "pd_gravity"), ("two_stage" + DOB, "two_stage"), ("two_stage" + INT, "two_stage"),
                               ("two_stage", "two_stage" + NOSWING)):
                    if a_ in means and b_ in means and means[b_] > 0:
                        rel.append(f"{100.0 * (means[a_] - means[b_]) / means[b_]:+.0f} %")
                    else:
                        rel.append("-")
                L.append(f"| {r} | " + " | ".join(cells) + " | " + " | ".join(rel) + " |")
    open(os.path.join(a.out, "tables.md"), "w").write("\n".join(L) + "\n")
    print("\n".join(L))
    plot(results, a.out, variants, refs, sorted({m for v in variants for m in mus_of(v)}), ctrls, seeds_of)
    if a.all and not a.tables_only:
        delay_evidence(a.build, a.out, gains)
        in_process(a.build, a.out)
        cmd = [sys.executable, os.path.join(HERE, "scripts", "hil_experiments.py"), "--build", a.build,
               "--out", os.path.join(a.out, "hil-experiments")]
        print("$ " + " ".join(cmd), flush=True)
        subprocess.run(cmd, check=True)


# why the extra cycle of delay faults on the lag plant and not with the hydraulics: the two-stage
# ID's trot, seed 1, the plant state every step (--truth-every 1), on three plants
EVIDENCE = {"lag 5 ms (ideal)": [], "lag 5 ms + 1 cycle delay": ["--delay-cycles", "1"],
            "hydraulics + 1 cycle delay": ["--hydraulics", "on", "--delay-cycles", "1"]}


def delay_evidence(build, out, gains):
    """Runs EVIDENCE and draws DIR/delay_evidence.png: the right front knee's velocity and torque
    around the trot's first lift-off, where the delayed lag plant faults."""
    rows = {}
    for k, (label, extra) in enumerate(EVIDENCE.items()):
        d = os.path.join(out, "evidence", f"run{k}")
        os.makedirs(d, exist_ok=True)
        cfg = config_for(d, build, "two_stage", gains)
        res = hyq_runs.judge(hyq_runs.run(d, "two_stage", build=build, servod_config=cfg,
                                          sim_args=["--seed", "1", "--truth-every", "1"] + extra))
        print(f"[evidence {k + 1}/{len(EVIDENCE)}] {label}: "
              f"{'stable' if res.get('stable') else res.get('why', '?')}", flush=True)
        truth = hyq_runs.read_truth(d)
        window = [k for k, t in enumerate(truth["t"]) if 2.0 <= t <= 3.0]
        rows[label] = tuple([truth[c][k] for k in window] for c in ("t", "qd_rf_kfe_joint", "tau_rf_kfe_joint")) + (res,)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    for label, (t, qd, tau, res) in rows.items():
        tag = label + ("" if res.get("stable") else "  (faulted: " + res.get("why", "") + ")")
        a1.plot(t, qd, lw=0.9, label=tag)
        a2.plot(t, tau, lw=0.9, label=tag)
    a1.axhline(15, color="k", ls=":", lw=0.8)
    a1.axhline(-15, color="k", ls=":", lw=0.8, label="safety limit ±15 rad/s")
    a1.set_ylabel("rf_kfe q̇ (rad/s)")
    a2.set_ylabel("rf_kfe applied τ (N·m)")
    a2.set_xlabel("simulated time (s): stand-up until 2.0 s, the trot's first lift-off at ~2.5 s")
    a1.legend(fontsize=7)
    a1.set_title("two-stage ID, tuned gains (kp_tau 837.9, kd_tau 28.2), trot μ = 0.1, seed 1")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "delay_evidence.png"), dpi=110)
    print("figure", os.path.join(out, "delay_evidence.png"))


def in_process(build, out):
    """docs/experiments.md's runs: hyq-experiment with the tuned gains, the untuned ones, and the
    paper's scenarios on the realistic plant (each prints its own progress)."""
    exe = os.path.join(build, "tools", "hyq-experiment", "hyq-experiment")
    paper = [x for sc in ("trot_mu0.1", "eight_mu0.1", "trot_mu1.0", "eight_mu1.0")
             for c in CTRLS for x in ("--scenario", f"{sc}_{c}")]
    for sub, args in (("inprocess", ["--all"]), ("inprocess-untuned", ["--all", "--gains", "untuned"]),
                      ("inprocess-realistic", paper + ["--profile", "realistic"])):
        cmd = [exe, "--out", os.path.join(out, sub)] + args
        print("$ " + " ".join(cmd), flush=True)
        subprocess.run(cmd, check=True)


def plot(R, out, variants, refs, mus, ctrls, seeds_of):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("no matplotlib: no figure")
        return
    panels = [(r, mu) for r in refs for mu in mus]
    ncol = len(mus)
    fig, axs = plt.subplots(len(refs), ncol, figsize=(9 * ncol, 4.2 * len(refs)), squeeze=False,
                            gridspec_kw={"width_ratios": [sum(any(n.startswith(f"{v}_{refs[0]}_mu{m}_") for n in R["runs"])
                                                              for v in variants) + 1 for m in mus]} if ncol > 1 else None)
    for ax, (r, mu) in zip(axs.flat, panels):
        # only the variants run on this mu
        pv = [v for v in variants if any(n.startswith(f"{v}_{r}_mu{mu}_") for n in R["runs"])]
        w = 0.8 / len(ctrls)
        for k, c in enumerate(ctrls):
            ys, es, xs, bad = [], [], [], []
            for j, v in enumerate(pv):
                rs = [R["runs"][n] for n in (f"{v}_{r}_mu{mu}_{c}_s{s}" for s in seeds_of(v)) if n in R["runs"]]
                e = [x["error"] for x in rs if "error" in x]
                ys.append(statistics.mean(e) if e else 0.0)
                es.append(statistics.stdev(e) if len(e) > 1 else 0.0)
                xs.append(j + (k - (len(ctrls) - 1) / 2) * w)
                bad.append(any(not x["stable"] for x in rs))
            ax.bar(xs, ys, w, yerr=es, label=c, capsize=2)
            for x, y, b in zip(xs, ys, bad):
                if b:
                    ax.text(x, y, "unstable", ha="center", va="bottom", fontsize=6, rotation=90)
        ax.set_xticks(range(len(pv)), pv, rotation=20, fontsize=8)
        ax.set_yscale("log")
        ax.set_ylabel("mean ‖q_ref − q‖ over ACTIVE (rad)")
        ax.set_title(f"{r}, μ = {mu}")
    axs[0][0].legend(fontsize=7, ncol=2)
    fig.suptitle("mean tracking error over ACTIVE through the loop; seeded variants: mean of 3 seeds, "
                 "error bars ± sd; 'unstable': a fault or a fall", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "baselines.png"), dpi=110)
    print("figure", os.path.join(out, "baselines.png"))


if __name__ == "__main__":
    main()
