#!/usr/bin/python3
"""The fault matrix through the loop: every fault kind hyq-sim injects, on each leg, the IMU, each
leg's bus and the daemon, at seeded phases of the trot and the Figure-Eight, on the ideal and the
realistic plant; each run judged by how the robot stopped (docs/servo.md, "Graded stops").

    /usr/bin/python3 scripts/fault_matrix.py [--out DIR] [--plants ideal,realistic]
                                             [--references trot,eight] [--phases N] [--seed N]
                                             [--quick] [--kinds K1,K2] [--build DIR]
                                             [--rerun-failed DIR/fault_matrix.json]

A run: the shipped simulation configuration, lock-step, 6 s of reference; the fault at a seeded
simulated time in [4.0, 5.5) s (the gait under way, at a seeded phase of its cycle), on a seeded
joint of each leg (haa, hfe or kfe). Each fault kind has the stop class it must give
(stop_class.h): the first fault event's class must be it (none: the hold rides through it, no
fault at all). Then:
  controlled, degraded   sat down: the trunk down at <= 0.5 m/s and tilted under 30 deg (hyq-sim's
                         sat_down), no fall, the daemon stopped
  cut                    the trunk's contact speed is reported; at most 0.5 m/s counts as down
                         gently, above as the measured best (the damping's, safety.damping_Nms_per_rad);
                         a trunk that never touched the ground is "held up": FAULT took the boards
                         out of OP with the robot still up, its joints locked by their closed valves
--quick: one target per fault kind per plant (seeded), the references taking turns: the CI set.
--rerun-failed: the runs that were not ok in an earlier fault_matrix.json, again (same specs).
Exit 1 when a run gave another stop class than its kind's, a run of class none faulted or fell,
or fewer than --min-sat-down of the controlled and degraded runs sat down (default 1: all).
Writes DIR/fault_matrix.json (every run) and DIR/fault_matrix.md (the tables), prints progress
and the tables.
"""
import argparse, json, os, random, sys, time

import hyq_runs

JOINTS = ["haa", "hfe", "kfe"]
# kind -> (hyq-sim's fault spec for a target, the target kind, the stop class it must give)
KINDS = {
    "silent": ("{t}:silent:{d}:1", "joint", "degraded"),      # the board silent for 1 s
    "corrupt": ("{t}:corrupt:{d}:20", "joint", "degraded"),   # 20 malformed frames
    "drop": ("{t}:drop:{d}:12", "joint", "degraded"),         # 12 answers lost: past the hold
    "drop_short": ("{t}:drop:{d}:3", "joint", "none"),        # 3 lost: held, extrapolated
    "nan": ("{t}:nan:{d}", "joint", "degraded"),              # a NaN load cell
    "emcy": ("{t}:emcy:{d}", "joint", "degraded"),            # the board faults (EMCY)
    "reset": ("{t}:reset:{d}", "joint", "degraded"),          # the board resets and boots again
    "imu_silent": ("{t}:silent:imu:1", "imu", "degraded"),
    "imu_corrupt": ("{t}:corrupt:imu:20", "imu", "degraded"),
    "imu_drop": ("{t}:drop:imu:12", "imu", "degraded"),
    "imu_nan": ("{t}:nan:imu", "imu", "degraded"),
    "imu_reset": ("{t}:reset:imu", "imu", "degraded"),
    "bus_off": ("{t}:bus-off:{d}:1", "bus", "cut"),           # a leg's bus off for 1 s
    "stall_7ms": ("{t}:stall:daemon:0.007", "daemon", "controlled"),  # under the boards' 8 ms
    "stall_19ms": ("{t}:stall:daemon:0.019", "daemon", "cut"),        # every board trips
}
PLANTS = ["ideal", "realistic"]
REFS = {"trot": "trot", "eight": "figure_eight"}


def plan(a):
    """The runs: (plant, reference, kind, target, time) in a seeded order."""
    if a.rerun_failed:
        try:
            rows = json.load(open(a.rerun_failed))["runs"]
            return [(r["plant"], r["reference"], r["kind"], r["target"], r["t_s"]) for r in rows
                    if not r["ok"]]
        except (OSError, ValueError, KeyError, TypeError) as e:
            sys.exit(f"fault_matrix.py: --rerun-failed {a.rerun_failed}: expected an earlier "
                     f"fault_matrix.json (runs with plant, reference, kind, target, t_s, ok), found: {e}")
    rng = random.Random(a.seed)
    kinds = a.kinds.split(",") if a.kinds else list(KINDS)
    runs = []
    for plant in a.plants:
        for i, kind in enumerate(kinds):
            tkind = KINDS[kind][1]
            targets = {"joint": [f"{leg}_{rng.choice(JOINTS)}" for leg in hyq_runs.LEGS],
                       "bus": list(hyq_runs.LEGS), "imu": ["imu"], "daemon": ["daemon"]}[tkind]
            refs = a.references
            if a.quick:  # one target, the references taking turns
                targets = [rng.choice(targets)]
                refs = [a.references[i % len(a.references)]]
            for ref in refs:
                for target in targets:
                    for _ in range(1 if a.quick else a.phases):
                        runs.append((plant, ref, kind, target, round(4.0 + 1.5 * rng.random(), 3)))
    return runs


def verdict(r, expected):
    """The run's stop class, outcome and whether it passes."""
    if r.servod is None or r.sim is None:
        return {"ok": False, "why": f"no summary ({r.missing})"}
    s, sim = r.servod, r.sim
    faults = [e for e in s["event_log"] if e.get("stop", "none") != "none"]
    got = faults[0]["stop"] if faults else "none"
    res = {"class": got, "first": faults[0]["reason"] if faults else "",
           "detail": faults[0]["detail"] if faults else "", "fell": bool(sim["fell"]),
           "sat_down": bool(sim["sat_down"]), "contact_m_s": round(sim["contact_speed_m_s"], 3),
           "tilt_deg": round(sim.get("contact_tilt_deg", 0.0), 1), "final_mode": s["final_mode"]}
    if got != expected:
        res.update(ok=False, why=f"stop class {got}, expected {expected}")
    elif expected == "none":
        res.update(ok=r.exit == 0 and not sim["fell"], why="" if r.exit == 0 else f"exit {r.exit}")
    elif expected == "cut":
        res.update(ok=True, gentle=sim["contact_speed_m_s"] <= 0.5 and not sim["fell"])
    else:
        good = sim["sat_down"] and not sim["fell"] and s["final_mode"] == "stopped"
        res.update(ok=good, why="" if good else ("fell" if sim["fell"] else "did not sit down") +
                   f" (contact {sim['contact_speed_m_s']:.2f} m/s, tilt {sim.get('contact_tilt_deg', 0):.0f} deg)")
    return res


def tables(rows):
    """Markdown: per fault kind and plant, the runs, how they ended and the worst contact."""
    out = ["| fault | class | plant | runs | sat down / down gently | fell | worst contact m/s | worst tilt deg |",
           "|---|---|---|---|---|---|---|---|"]
    for kind in KINDS:
        for plant in PLANTS:
            rs = [r for r in rows if r["kind"] == kind and r["plant"] == plant and "class" in r]
            if not rs:
                continue
            exp = KINDS[kind][2]
            if exp == "none":
                down = sum(1 for r in rs if r["ok"])
                out.append(f"| {kind} | {exp} | {plant} | {len(rs)} | {down} rode through | "
                           f"{sum(r['fell'] for r in rs)} | - | - |")
                continue
            down = sum(1 for r in rs if (r.get("gentle") if exp == "cut" else r["ok"]))
            touched = [r for r in rs if r["sat_down"] or r["fell"]]
            worst = max((r["contact_m_s"] for r in touched), default=0.0)
            tilt = max((r["tilt_deg"] for r in touched), default=0.0)
            # a cut whose trunk never reached the ground: FAULT took every board out of OP with the
            # robot still up, its joints locked by their closed valves
            held = len(rs) - len(touched)
            gently = f"{down} ({held} held up)" if exp == "cut" and held else f"{down}"
            out.append(f"| {kind} | {exp} | {plant} | {len(rs)} | {gently} | {sum(r['fell'] for r in rs)} | "
                       f"{worst:.2f} | {tilt:.0f} |")
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--out", default="fault-matrix", help="output folder (default: fault-matrix)")
    ap.add_argument("--plants", default="ideal,realistic", help="ideal and/or realistic (default both)")
    ap.add_argument("--references", default="trot,eight", help="trot and/or eight (default both)")
    ap.add_argument("--phases", type=int, default=1, help="fault times per target (default 1)")
    ap.add_argument("--seed", type=int, default=1, help="the plan's and hyq-sim's seed (default 1)")
    ap.add_argument("--kinds", help="comma-separated fault kinds (default all: " + ",".join(KINDS) + ")")
    ap.add_argument("--quick", action="store_true", help="one target per kind and plant (the CI set)")
    ap.add_argument("--min-sat-down", type=float, default=1.0,
                    help="the fraction of controlled and degraded runs that must sit down (default 1)")
    ap.add_argument("--build", default=hyq_runs.DEFAULT_BUILD, help="build tree (default build/ci)")
    ap.add_argument("--rerun-failed", metavar="JSON",
                    help="run again the runs that failed in this earlier fault_matrix.json")
    a = ap.parse_args()
    a.plants = [p for p in a.plants.split(",") if p]
    a.references = [r for r in a.references.split(",") if r]
    for p in a.plants:
        if p not in PLANTS:
            ap.error(f"--plants: expected ideal or realistic, found '{p}'")
    for r in a.references:
        if r not in REFS:
            ap.error(f"--references: expected trot or eight, found '{r}'")
    for k in (a.kinds.split(",") if a.kinds else []):
        if k not in KINDS:
            ap.error(f"--kinds: expected some of {','.join(KINDS)}, found '{k}'")
    if not 1 <= a.phases <= 20:
        ap.error(f"--phases: expected 1..20, found {a.phases}")
    hyq_runs.require_tools(a.build, ["hyq-sim", "hyq-servod"], "fault_matrix.py")
    os.makedirs(a.out, exist_ok=True)
    runs, rows, t0 = plan(a), [], time.time()
    with open(os.path.join(a.out, "runs.log"), "w") as log:
        for i, (plant, ref, kind, target, t) in enumerate(runs):
            spec_t, tkind, expected = KINDS[kind]
            device = target if tkind != "daemon" else "daemon"
            spec = spec_t.format(t=t, d=device)
            name = f"{plant}_{ref}_{kind}_{target}_{t}"
            sim_args = hyq_runs.plant_args(plant, a.seed) + ["--seed", str(a.seed), "--fault", spec]
            r = hyq_runs.run(os.path.join(a.out, name), "two_stage", retries=1, log=log, build=a.build,
                             reference=REFS[ref], duration_s=6.0, sim_args=sim_args)
            v = verdict(r, expected)
            rows.append(dict(plant=plant, reference=ref, kind=kind, target=target, t_s=t, spec=spec,
                             expected=expected, **v))
            mark = "ok  " if v["ok"] else "FAIL"
            print(f"[{i + 1}/{len(runs)} {time.time() - t0:5.0f} s] {mark} {plant:9s} {ref:5s} {spec:28s} "
                  f"-> {v.get('class', '?'):10s} {'fell' if v.get('fell') else 'sat' if v.get('sat_down') else '-':4s} "
                  f"{v.get('contact_m_s', 0):.2f} m/s {v.get('tilt_deg', 0):4.0f} deg {v.get('why', '')}", flush=True)
    md = tables(rows)
    with open(os.path.join(a.out, "fault_matrix.json"), "w") as f:
        json.dump({"seed": a.seed, "quick": a.quick, "runs": rows}, f, indent=1)
    with open(os.path.join(a.out, "fault_matrix.md"), "w") as f:
        f.write(md + "\n")
    print(md)
    wrong = [r for r in rows if r.get("class") != r["expected"] or (r["expected"] == "none" and not r["ok"])]
    stops = [r for r in rows if r["expected"] in ("controlled", "degraded")]
    sat = sum(1 for r in stops if r["ok"])
    frac = sat / len(stops) if stops else 1.0
    print(f"fault_matrix.py: {len(rows) - len(wrong)} of {len(rows)} runs gave their stop class "
          f"(or rode through); {sat} of {len(stops)} controlled and degraded stops sat down "
          f"({100 * frac:.0f} %, required {100 * a.min_sat_down:.0f} %; {time.time() - t0:.0f} s wall)")
    for r in wrong:
        print(f"fault_matrix.py: {r['plant']} {r['reference']} {r['spec']}: stop class {r.get('class')}, "
              f"expected {r['expected']} ({r.get('first', '')}: {r.get('detail', '')})")
    return 1 if wrong or frac < a.min_sat_down else 0


if __name__ == "__main__":
    sys.exit(main())
