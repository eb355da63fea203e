"""One run of the loop for the experiment scripts, and the controllers and plants they compare.

A run is scripts/hil.sh: hyq-sim (the MuJoCo plant behind its boards) and hyq-servod (the daemon)
on the virtual CAN buses of a private network namespace, lock-step unless told otherwise, in a
folder of its own. run() builds the command line, runs it and reads what the two programs and
hil.sh wrote (servod.json, sim.json, hil.json) into a Run; judge() tells whether the daemon
stopped under control with the robot standing, and how well it tracked; read_truth() reads the
plant's truth.csv and feet() the feet's positions of its rows, from tools/hyq-kinematics (the
servo's own model, config/robots/hyq.urdf).

scripts/tune_gains.py, scripts/baseline_experiments.py and scripts/hil_experiments.py import it
(they run from scripts/, which Python puts first on the path).
"""
import json, os, subprocess, time

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_BUILD = os.path.join(HERE, "build", "ci")

CONTROLLERS = ["pid", "pd_gravity", "noslip", "two_stage"]
# the scripts' short names of hil.sh's references; "steer" is the trot steered by a script of
# set-velocity commands (hyq-servod --steer, reference time): forward faster, then a left turn,
# then sideways turning right
REFERENCES = {"trot": "trot", "eight": "figure_eight", "steer": "trot"}
STEER = ["2:0.3,0,0", "6:0.2,0,0.4", "12:0.1,0.1,-0.3"]
LEGS = ["lf", "rf", "lh", "rh"]

# sensor noise and actuator lag (hyq-sim's default lag is 5 ms)
LOAD_CELL_NOISE = "2"          # N m at the joint, sigma
IMU_NOISE = "0.01,0.1"         # gyro rad/s, accelerometer m/s^2, sigma
ACTUATOR_TAU = "0.005"         # s

# The plants: name -> hyq-sim arguments, "{seed}" standing for the run's seed. "ideal" is
# hyq-sim's default plant; the next ones switch one factor of the realistic profile on at its
# level (docs/simulation.md, "Plant profiles"), then all of them together. Last, the default
# plant with sensor noise and actuator lag on and off one at a time.
PLANTS = {
    "ideal": [],
    "payload": ["--payload", "1,0.10,0.05,0.08"],
    "payload_3kg": ["--payload", "3,0.10,0.05,0.08"],
    "link_errors": ["--link-errors", "{seed}"],
    "joint_friction": ["--joint-friction", "on"],
    "delay": ["--delay-cycles", "1"],
    "biases": ["--load-cell-bias", "1.0", "--imu-bias", "0.0035,0.05", "--bias-seed", "{seed}"],
    "hydraulics": ["--hydraulics", "on"],
    "realistic_no_hydraulics": ["--profile", "realistic", "--hydraulics", "off", "--link-errors", "{seed}",
                                "--bias-seed", "{seed}"],
    "realistic": ["--profile", "realistic", "--link-errors", "{seed}", "--bias-seed", "{seed}"],
    "full": ["--actuator-tau", ACTUATOR_TAU, "--load-cell-noise", LOAD_CELL_NOISE, "--imu-noise", IMU_NOISE],
    "no_noise": ["--actuator-tau", ACTUATOR_TAU],
    "no_lag": ["--actuator-tau", "0", "--load-cell-noise", LOAD_CELL_NOISE, "--imu-noise", IMU_NOISE],
    "no_lag_no_noise": ["--actuator-tau", "0"],
}
# the plants in which the seed draws something (link errors, sensor biases); in the others only
# hyq-sim's own --seed (the sensor noise) does
SEEDED_PLANTS = {"link_errors", "biases", "realistic_no_hydraulics", "realistic"}


def plant_args(plant, seed):
    """hyq-sim's arguments for `plant` with `seed` in place of "{seed}"."""
    return [a.replace("{seed}", str(seed)) for a in PLANTS[plant]]


class Run:
    """What one run left in its folder: the command, its exit status and output, and the
    summaries (None where a file is missing or unreadable; `missing` then says which and why)."""

    def __init__(self, out, command, exit_code, output):
        self.out, self.command, self.exit, self.output = out, command, exit_code, output
        self.servod = self.sim = self.hil = None
        self.missing = None
        try:
            self.servod = read_json(os.path.join(out, "servod.json"))
            self.sim = read_json(os.path.join(out, "sim.json"))
            self.hil = read_json(os.path.join(out, "hil.json"))
        except (OSError, ValueError) as e:
            self.missing = str(e)

    def summaries(self):
        """(servod.json, sim.json, hil.json); exits naming the run when one is missing."""
        if self.missing:
            raise SystemExit(f"{self.out}: no summary ({self.missing}); hil.sh said: {self.output[-300:]}")
        return self.servod, self.sim, self.hil


def read_json(path):
    with open(path) as f:
        return json.load(f)


def command(out, controller, build=DEFAULT_BUILD, reference="trot", duration_s=5.0, mu=0.1,
            sim_args=(), servod_config=None, clock="lockstep", steer=()):
    """scripts/hil.sh's command line for one run into folder `out`: `reference` (hil.sh's name)
    for `duration_s` of ACTIVE time with `controller` on ground friction `mu`, hyq-sim's
    arguments `sim_args`, the daemon's configuration file `servod_config` (default: hil.sh's,
    the shipped simulation configuration), `steer` hyq-servod --steer commands, no LCM logger."""
    cmd = [os.path.join(HERE, "scripts", "hil.sh"), "--build", build, "--out", out, "--quiet", "--no-logger",
           "--clock", clock, "--duration", str(duration_s), "--reference", reference,
           "--controller", controller, "--mu", str(mu)]
    if servod_config:
        cmd += ["--servod-arg", "--config", "--servod-arg", servod_config]
    for s in steer:
        cmd += ["--servod-arg", "--steer", "--servod-arg", s]
    for a in sim_args:
        cmd += ["--sim-arg", a]
    return cmd


def run(out, controller, retries=0, log=None, reuse=False, **kw):
    """Runs command(out, controller, **kw) and reads its folder. retries: runs again (that many
    times at most) while no servod.json came out, as when a bring-up lost a port to another
    process ('bind: Address already in use'). log: a file the command, its output, exit status
    and wall time are appended to. reuse: a folder a run with the same command completed
    (OUT/cmd.txt, the command every run leaves) is read, not run again."""
    cmd = command(out, controller, **kw)
    os.makedirs(out, exist_ok=True)
    cmd_file = os.path.join(out, "cmd.txt")
    line = " ".join(cmd)
    done = [os.path.join(out, f) for f in ("servod.json", "sim.json", "hil.json", "cmd.txt")]
    if reuse and all(os.path.exists(f) for f in done) and open(cmd_file).read() == line:
        if log:
            log.write("# reused " + out + "\n")
        return Run(out, cmd, 0, "")
    for _ in range(retries + 1):
        t = time.time()
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if log:
            log.write("$ " + line + "\n" + p.stdout + f"(exit {p.returncode}, {time.time() - t:.1f} s wall)\n\n")
            log.flush()
        if os.path.exists(done[0]):
            break
    with open(cmd_file, "w") as f:
        f.write(line)
    return Run(out, cmd, p.returncode, p.stdout)


def judge(r):
    """The verdict on a run, as the tuning and the baselines record it: stable (exit 0, no fault
    event, the robot did not fall, the daemon stopped), the mean and max tracking error over
    ACTIVE, the faults, a fall (while ACTIVE or after), and why not stable."""
    res = {"exit": r.exit}
    if r.servod is None or r.sim is None:
        res.update(stable=False, why=f"no summary ({r.missing}); hil.sh said: {r.output[-300:]}")
        return res
    s, sim = r.servod, r.sim
    faults = [e["reason"] for e in s["event_log"] if e["to"] in ("damping", "fault") and e["reason"] != "stop_request"]
    fell_active = sim.get("fell", False) and sim.get("fell_at_s", 0) < sim.get("released_at_s", 0) + s["active_s"]
    res.update(error=s["tracking_error_mean_rad"], error_max=s["tracking_error_max_rad"],
               peak_rad_s=s.get("joint_speed_max_rad_s", float("nan")),
               peak_joint=s.get("joint_speed_max_joint", ""), active_s=s["active_s"], final_mode=s["final_mode"], faults=faults,
               fell=bool(sim.get("fell", False)), fell_while_active=bool(fell_active))
    res["stable"] = r.exit == 0 and not faults and not sim.get("fell", False) and s["final_mode"] == "stopped"
    if not res["stable"]:
        res["why"] = (f"exit {r.exit}" + (f", faults {faults}" if faults else "") +
                      (", fell" if sim.get("fell") else ""))
    return res


def read_csv_columns(lines):
    """A CSV with a header, as {column: [float, ...]}."""
    head = next(lines).strip().split(",")
    cols = [[] for _ in head]
    for line in lines:
        if line.strip():
            for c, v in zip(cols, line.split(",")):
                c.append(float(v))
    return dict(zip(head, cols))


def read_truth(out):
    """The plant's truth.csv of run folder `out` (hyq-sim --truth: time, base pose, joint angles,
    rates and torques, contacts), as {column: [float, ...]}."""
    with open(os.path.join(out, "truth.csv")) as f:
        return read_csv_columns(iter(f))


def feet(build, truth_csv):
    """The feet of each row of `truth_csv` from tools/hyq-kinematics --orientation: {column:
    [float, ...]} with <leg>_x/_y/_z (the foot sphere's centre, world, m), <leg>_cx/_cy/_cz (its
    lowest point) and <leg>_R00 .. _R22 (the foot frame's rotation, row by row)."""
    tool = os.path.join(build, "tools", "hyq-kinematics", "hyq-kinematics")
    p = subprocess.run([tool, "--orientation", truth_csv], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       text=True)
    if p.returncode != 0:
        raise SystemExit(f"{tool} {truth_csv}: exit {p.returncode}: {p.stderr.strip()}")
    return read_csv_columns(iter(p.stdout.splitlines()))


def require_tools(build, names, script):
    """Exits naming the first of `names` (tools/<name>/<name>) that `build` lacks."""
    for n in names:
        if not os.access(os.path.join(build, "tools", n, n), os.X_OK):
            raise SystemExit(f"{script}: {build}/tools/{n}/{n} not built (cmake --build --preset ci)")
