// hyq-sim: the simulated HyQ. The MuJoCo plant behind HyQ's 12 actuator boards and
// IMU (hyq::sim::SimulatedRobot) on virtual CAN (udp::43101..43104 for lf, rf, lh, rh by default)
// or SocketCAN, so that the unmodified servo daemon drives it like the real robot.
// docs/simulation.md describes the modes, the models, the faults and this command line.
#include <sched.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include "config/hal_config_loader.h"
#include "drivers/channel_factory.h"
#include "dynamics/urdf_loader.h"
#include "hal/clock.h"
#include "servo/runtime/realtime_thread.h"
#include "sim/fault_spec.h"
#include "sim/realtime_runner.h"
#include "sim/simulated_robot.h"
#include "tools/cli/command_line.h"
#include "tools/cli/install_paths.h"
#include "tools/plant_flags/plant_profile_flags.h"
#include "hyq_lcm/lcmt_hyq_sim_truth.hpp"

namespace {

using Json = nlohmann::ordered_json;  // the summary's keys in the order written

constexpr const char* kTool = "hyq-sim";
constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";
constexpr const char* kTruthChannel = "HYQ_SIM_TRUTH";

struct Options {
  std::string config = hyq::cli::DefaultHalConfig();
  std::string urdf = hyq::cli::DefaultUrdf();
  std::map<std::string, std::string> interfaces;  // bus name → channel spec
  bool lockstep = true;
  hyq::sim::SimulatedRobotConfig robot;
  double duration_s = 0.0;
  std::vector<std::string> faults;
  std::string truth, summary;
  int truth_every = 10;
  std::string lcm_truth_url;  // empty: no HYQ_SIM_TRUTH
  int lcm_truth_every = 10;
  bool quiet = false;
  // real time only: the stepping thread below the servo thread (SCHED_FIFO 80), memory locked,
  // on CPU 0 where two cores exist (the daemon's servo thread takes the last one)
  int rt_priority = 70;
  int cpu = hyq::servo::kAutoCpu;
  // real time only: the boards answer SYNCs from a thread of their own (SimulatedRobot's bus
  // thread) on the servo's core (the last CPU), SCHED_FIFO below the servo thread: a stalled
  // physics core then leaves no SYNC unanswered, as the real boards answer whatever the
  // physics does
  bool bus_thread = true;
  int bus_priority = 75;
  int bus_cpu = hyq::servo::kAutoCpu;
  std::vector<std::pair<double, double>> stalls;  // --stall T:MS (simulated s, wall ms)
  std::string write_model;  // write the plant's MJCF (with its model error) here and exit
};

// -h / --help
std::string Help() {
  return std::string(
      "usage: hyq-sim [--config FILE] [--urdf FILE] [--interface BUS=SPEC]...\n"
      "               [--mode lockstep|realtime] [--duration S] [--mu MU] [--foot-mu A,B,C,D]\n"
      "               [--ground-patch X0,X1,Y0,Y1,MU]... [--box X0,X1,Y0,Y1,H]...\n"
      "               [--actuator-tau S] [--actuator-rate-limit NM_S] [--no-hold]\n"
      "               [--start-height M] [--seed N]\n"
      "               [--profile ideal|realistic] [--payload KG,X,Y,Z|off] [--link-errors SEED|off]\n"
      "               [--hydraulics on|off] [--joint-friction on|off] [--delay-cycles K]\n"
      "               [--load-cell-bias NM] [--imu-bias G,A] [--bias-seed N] [--load-cell-noise NM]\n"
      "               [--encoder-noise RAD] [--imu-noise GYRO[,ACCEL]] [--joint-velocity board|exact]\n"
      "               [--velocity-cutoff HZ] [--write-model FILE]\n"
      "               [--fault T:KIND:TARGET[:ARG]]... [--truth FILE] [--truth-every N]\n"
      "               [--lcm-truth [URL]] [--lcm-truth-every N]\n"
      "               [--summary FILE] [--fall-height M] [--rt-priority P] [--cpu N|auto]\n"
      "               [--bus-thread on|off] [--bus-priority P] [--bus-cpu N|auto] [--sync-phase US|off]\n"
      "               [--stall T:MS]...\n"
      "               [--quiet]\n"
      "The simulated HyQ: the MuJoCo plant behind HyQ's actuator boards and IMU on CAN, driven\n"
      "by the servo daemon (or any HAL master) through NMT, SYNC and RPDOs. docs/simulation.md.\n"
      "  --config FILE          HAL configuration (default @config@/hyq_hal.yaml)\n"
      "  --urdf FILE            robot model (default @config@/robots/hyq.urdf)\n"
      "  --interface BUS=SPEC   bus BUS on SPEC (docs/drivers.md). Default: the virtual buses\n"
      "                         udp::43101 (lf), udp::43102 (rf), udp::43103 (lh), udp::43104 (rh)\n"
      "  --mode M               lockstep (default): one physics step per SYNC seen on every bus,\n"
      "                         deterministic, as fast as the master; realtime: 1 kHz on\n"
      "                         CLOCK_MONOTONIC, SYNCs answered with the latest state\n"
      "  --duration S           stop after S simulated seconds (default 0: until SIGINT/SIGTERM)\n"
      "  --mu MU                ground friction (default 1.0)\n"
      "  --foot-mu A,B,C,D      per-foot friction lf,rf,lh,rh (negative: the ground's)\n"
      "  --ground-patch X0,X1,Y0,Y1,MU  a rectangle of the ground (world x, y in m) with friction\n"
      "                         MU; a foot above it has that μ (repeatable; the first listed wins)\n"
      "  --box X0,X1,Y0,Y1,H    a step: a box on the floor over that rectangle (world x, y in m),\n"
      "                         its top H m high, 0 < H <= 0.3 (repeatable). A step up: a box\n"
      "                         where a foot lands; a step down of H: a platform the robot starts\n"
      "                         on and walks off. Feet over a box start on its top\n"
      "  --actuator-tau S       actuator time constant (default 0.005; 0 = ideal)\n"
      "  --actuator-rate-limit R  torque rate limit, N·m/s (default 0 = none)\n"
      "  --no-hold              do not hold the robot on its stand until all outputs are enabled\n"
      "  --start-height M       the posture it is held in: base height with the feet on the ground\n"
      "                         (default 0.40: HyQ's resting crouch, which the daemon stands up\n"
      "                         from; 0: the standing posture)\n"
      "  --seed N               sensor-noise seed (default 1)\n"
      "  --profile P            the plant: ideal (default: the model, --actuator-tau lag, no sensor\n"
      "                         noise) or realistic (model error, HyQ's hydraulics with the boards'\n"
      "                         torque loop, joint friction, 1-cycle delay, sensor biases and noise;\n"
      "                         levels and sources in docs/simulation.md). The flags below change\n"
      "                         one factor of it, whatever their order:\n"
      "  --payload KG,X,Y,Z|off a point mass on the trunk (kg; position in the trunk frame, m)\n"
      "  --link-errors SEED|off per-link mass ±5 %, CoM ±1 cm, inertia ±10 % drawn from SEED\n"
      "  --hydraulics on|off    HyQ's hydraulic actuators and torque loop instead of the lag\n"
      "  --joint-friction on|off  Coulomb + viscous joint friction (realistic's levels)\n"
      "  --delay-cycles K       set-points take effect K plant steps later (0..50)\n"
      "  --load-cell-bias NM    per-joint load-cell offsets, uniform in ±NM, from --bias-seed\n"
      "  --imu-bias G,A         gyro (rad/s) and accelerometer (m/s²) biases per axis, uniform in\n"
      "                         ±G, ±A\n"
      "  --bias-seed N          seed of the sensor biases (default 1)\n"
      "  --load-cell-noise NM   σ of the measured joint torque, N·m (ideal 0, realistic 0.1)\n"
      "  --encoder-noise RAD    σ added to the joint angle before quantisation (ideal 0,\n"
      "                         realistic 1.2e-5)\n"
      "  --imu-noise G[,A]      σ of the gyro (rad/s) and accelerometer (m/s²) per 1 ms sample\n"
      "                         (ideal 0,0; realistic 0.0166,0.0248)\n"
      "  --joint-velocity V     board (default, every profile): the boards' velocity, the\n"
      "                         difference of successive encoder counts over the step through a\n"
      "                         first-order low-pass; exact: the plant's own velocity (what\n"
      "                         runs without the boards' velocity had)\n"
      "  --velocity-cutoff HZ   the boards' low-pass cut-off (default 250; 0: the bare difference)\n"
      "  --write-model FILE     write the plant's MuJoCo model (MJCF, model error included) and exit\n"
      "  --fault T:KIND:TARGET[:ARG]  at simulated time T: silent|corrupt|drop|nan|bus-off|emcy|\n"
      "                         reset|stall; TARGET a device (lf_kfe, imu), for bus-off a bus (rh),\n"
      "                         for stall daemon; ARG frames (corrupt, drop), seconds (silent,\n"
      "                         bus-off), code (emcy). reset: the device resets and boots again,\n"
      "                         silent for ARG s (default 0.05), then boot-up and PRE-OPERATIONAL.\n"
      "                         stall (lock-step only): the daemon stalls for ARG s (required):\n"
      "                         the plant steps on without its SYNCs, the boards holding their\n"
      "                         set-points (until their own timer trips them), then the daemon is\n"
      "                         told the periods it lost. e.g. 2.5:silent:lf_kfe\n"
      "                         3.0:corrupt:rf_hfe:20 4.0:bus-off:rh 5.0:reset:lf_kfe\n"
      "                         5.0:stall:daemon:0.019\n"
      "  --truth FILE           ground-truth CSV (t, base pose, q, qd, applied tau, contacts,\n"
      "                         each foot's friction, the base's linear (W) and angular (B)\n"
      "                         velocity)\n"
      "  --truth-every N        one truth row every N steps (default 10)\n"
      "  --lcm-truth [URL]      publish the truth as lcmt_hyq_sim_truth on HYQ_SIM_TRUTH (default\n"
      "                         URL ") +
         kDefaultLcmUrl +
         "; off unless given), for hyq-viewer's ghost\n"
         "  --lcm-truth-every N    one HYQ_SIM_TRUTH message every N steps (default 10)\n"
         "  --summary FILE         JSON at exit (time, fell, min base height, SYNCs per bus, speed)\n"
         "  --fall-height M        the base below this height above the ground (floor or box) under\n"
         "                         it, or the trunk or a leg on the ground,\n"
         "                         is a ground contact (default 0.2): a sit-down when the base comes\n"
         "                         down at most 0.5 m/s with the trunk upright, else a fall\n"
         "  --rt-priority P        realtime mode: SCHED_FIFO priority of the stepping thread, below\n"
         "                         the servo thread's 80, with mlockall (default 70; 0: SCHED_OTHER)\n"
         "  --cpu N|auto           realtime mode: pin the stepping thread to CPU N (-1: do not pin;\n"
         "                         default auto: CPU 0 where two or more cores are allowed)\n"
         "  --bus-thread on|off    realtime mode: the boards answer SYNCs from a thread of their own\n"
         "                         with the latest state, so a late or stalled physics step leaves\n"
         "                         no SYNC unanswered (default on; off: the stepping thread answers\n"
         "                         between its steps)\n"
         "  --bus-priority P       its SCHED_FIFO priority (default 75: below the servo thread's 80;\n"
         "                         0: SCHED_OTHER)\n"
         "  --bus-cpu N|auto       pin it to CPU N (-1: do not pin; default auto: the last CPU, the\n"
         "                         servo thread's, where two or more cores are allowed)\n"
         "  --sync-phase US|off    realtime mode: each physics step begins US µs after the master's\n"
         "                         SYNC (a phase lock on the step deadlines), so a set-point acts\n"
         "                         from the next step as in lockstep (default 500: half a period,\n"
         "                         room for the daemon's cycle before and the step before the next\n"
         "                         SYNC); off: the steps keep the phase the start gave them, and the\n"
         "                         loop's delay is 1 or 2 ms by chance (docs/simulation.md)\n"
         "  --stall T:MS           at simulated time T, stall the stepping thread for MS ms of wall\n"
         "                         time (what a preempted core does to the plant; tests)\n"
            "  --quiet                no progress line on stderr\n";
}

constexpr double kNoMax = std::numeric_limits<double>::max();

// --rt-priority, --bus-priority
int Priority(hyq::cli::CommandLine& cl) {
  return static_cast<int>(cl.Integer(0, 99, "a priority 0..99"));
}

// --cpu, --bus-cpu
int Cpu(hyq::cli::CommandLine& cl) {
  const std::string v = cl.Value();
  if (v == "auto") return hyq::servo::kAutoCpu;
  const std::optional<long long> c = hyq::cli::ParseInteger(v);
  if (!c || *c < -1 || *c > std::numeric_limits<int>::max())
    cl.BadValue("a CPU number >= -1 or auto", v);
  return static_cast<int>(*c);
}

// on|off as a bool
bool OnOff(hyq::cli::CommandLine& cl) {
  const std::string v = cl.Value();
  if (v != "on" && v != "off") cl.BadValue("on or off", v);
  return v == "on";
}

// --ground-patch X0,X1,Y0,Y1,MU
hyq::sim::GroundPatch GroundPatch(hyq::cli::CommandLine& cl) {
  const std::string v = cl.Value();
  const std::vector<std::string> f = hyq::cli::Split(v, ',');
  if (f.size() != 5) cl.BadValue("five numbers X0,X1,Y0,Y1,MU", v);
  hyq::sim::GroundPatch p;
  p.x0_m = cl.NumberOf("--ground-patch X0", f[0]);
  p.x1_m = cl.NumberOf("--ground-patch X1", f[1]);
  p.y0_m = cl.NumberOf("--ground-patch Y0", f[2]);
  p.y1_m = cl.NumberOf("--ground-patch Y1", f[3]);
  p.mu = cl.NumberOf("--ground-patch MU", f[4], 0.0, kNoMax, "a friction coefficient >= 0");
  if (!(p.x0_m < p.x1_m) || !(p.y0_m < p.y1_m)) cl.BadValue("X0 < X1 and Y0 < Y1", v);
  return p;
}

// --box X0,X1,Y0,Y1,H
hyq::sim::GroundBox Box(hyq::cli::CommandLine& cl) {
  const std::string v = cl.Value();
  const std::vector<std::string> f = hyq::cli::Split(v, ',');
  if (f.size() != 5) cl.BadValue("five numbers X0,X1,Y0,Y1,H", v);
  constexpr double kMaxM = 1000.0;
  const char* const where = "metres in [-1000, 1000]";
  hyq::sim::GroundBox b;
  b.x0_m = cl.NumberOf("--box X0", f[0], -kMaxM, kMaxM, where);
  b.x1_m = cl.NumberOf("--box X1", f[1], -kMaxM, kMaxM, where);
  b.y0_m = cl.NumberOf("--box Y0", f[2], -kMaxM, kMaxM, where);
  b.y1_m = cl.NumberOf("--box Y1", f[3], -kMaxM, kMaxM, where);
  // resting on the floor, so higher than it; 0.3 m is half HyQ's standing leg length
  const char* const height = "a height in (0, 0.3] m (a step down is a platform to walk off)";
  b.height_m = cl.NumberOf("--box H", f[4], 0.0, 0.3, height);
  if (b.height_m == 0.0) cl.Bad("--box H", height, f[4]);
  if (!(b.x0_m < b.x1_m) || !(b.y0_m < b.y1_m)) cl.BadValue("X0 < X1 and Y0 < Y1", v);
  return b;
}

// --fault T:KIND:TARGET[:ARG]: the time and the kind now; the target and the argument when the
// HAL configuration is loaded (sim::ParseFaultSpec)
std::string Fault(hyq::cli::CommandLine& cl) {
  const std::string v = cl.Value();
  const std::vector<std::string> f = hyq::cli::Split(v, ':');
  if (f.size() != 3 && f.size() != 4) cl.BadValue("T:KIND:TARGET[:ARG]", v);
  (void)cl.NumberOf("--fault T", f[0], 0.0, kNoMax, "simulated seconds >= 0");
  using Kind = hyq::sim::FaultSpec::Kind;
  std::string kinds;
  for (Kind k : {Kind::kSilent, Kind::kCorrupt, Kind::kDrop, Kind::kNan, Kind::kBusOff, Kind::kEmcy,
                 Kind::kReset, Kind::kStall}) {
    if (f[1] == hyq::sim::ToString(k)) return v;
    if (!kinds.empty()) kinds += '|';
    kinds += hyq::sim::ToString(k);
  }
  cl.Bad("--fault KIND", kinds, f[1]);
}

Options Parse(hyq::cli::CommandLine& cl) {
  using hyq::cli::Split;
  Options o;
  hyq::cli::PlantProfileFlags plant(/*sensors=*/true);
  while (cl.Next()) {
    if (plant.Read(cl)) continue;
    if (cl.Flag("--config")) o.config = cl.Value();
    else if (cl.Flag("--urdf")) o.urdf = cl.Value();
    else if (cl.Flag("--interface")) {
      auto [bus, spec] = cl.KeyValue("BUS=SPEC");
      o.interfaces[std::move(bus)] = std::move(spec);
    } else if (cl.Flag("--mode")) {
      const std::string v = cl.Value();
      if (v != "lockstep" && v != "realtime") cl.BadValue("lockstep or realtime", v);
      o.lockstep = v == "lockstep";
    } else if (cl.Flag("--duration")) o.duration_s = cl.Number(0.0, kNoMax, "simulated seconds >= 0");
    else if (cl.Flag("--mu"))
      o.robot.plant.ground_mu = cl.Number(0.0, kNoMax, "a friction coefficient >= 0");
    else if (cl.Flag("--foot-mu")) {
      const std::string v = cl.Value();
      const std::vector<std::string> p = Split(v, ',');
      if (p.size() != 4) cl.BadValue("four comma-separated coefficients A,B,C,D", v);
      const char* const parts[] = {"--foot-mu A", "--foot-mu B", "--foot-mu C", "--foot-mu D"};
      for (std::size_t f = 0; f < 4; ++f) o.robot.plant.foot_mu[f] = cl.NumberOf(parts[f], p[f]);
    } else if (cl.Flag("--ground-patch")) o.robot.plant.patches.push_back(GroundPatch(cl));
    else if (cl.Flag("--box")) o.robot.plant.boxes.push_back(Box(cl));
    else if (cl.Flag("--actuator-tau")) o.robot.actuator_tau_s = cl.Number(0.0, kNoMax, "seconds >= 0");
    else if (cl.Flag("--actuator-rate-limit"))
      o.robot.actuator_rate_limit_Nm_s = cl.Number(0.0, kNoMax, "N·m/s >= 0");
    else if (cl.Flag("--no-hold")) o.robot.hold = false;
    else if (cl.Flag("--start-height")) {
      const std::string expected = "0 or a base height in [0.34, 0.62] m";
      const std::string v = cl.Value();
      const double h = cl.NumberOf("--start-height", v, 0.0, kNoMax, expected);
      if (h != 0.0 && (h < 0.34 || h > 0.62)) cl.BadValue(expected, v);
      o.robot.start_height_m = h;
    } else if (cl.Flag("--seed")) {
      o.robot.seed = static_cast<std::uint64_t>(
          cl.Integer(0, std::numeric_limits<long long>::max(), "an unsigned integer"));
    } else if (cl.Flag("--fault")) o.faults.push_back(Fault(cl));
    else if (cl.Flag("--write-model")) o.write_model = cl.Value();
    else if (cl.Flag("--truth")) o.truth = cl.Value();
    else if (cl.Flag("--truth-every"))
      o.truth_every = static_cast<int>(cl.Integer(1, std::numeric_limits<int>::max(), "an integer >= 1"));
    else if (cl.Flag("--lcm-truth")) o.lcm_truth_url = cl.OptionalValue().value_or(kDefaultLcmUrl);
    else if (cl.Flag("--lcm-truth-every"))
      o.lcm_truth_every = static_cast<int>(cl.Integer(1, std::numeric_limits<int>::max(), "an integer >= 1"));
    else if (cl.Flag("--summary")) o.summary = cl.Value();
    else if (cl.Flag("--fall-height")) o.robot.fall_height_m = cl.Number(0.0, kNoMax, "metres >= 0");
    else if (cl.Flag("--rt-priority")) o.rt_priority = Priority(cl);
    else if (cl.Flag("--cpu")) o.cpu = Cpu(cl);
    else if (cl.Flag("--bus-thread")) o.bus_thread = OnOff(cl);
    else if (cl.Flag("--bus-priority")) o.bus_priority = Priority(cl);
    else if (cl.Flag("--bus-cpu")) o.bus_cpu = Cpu(cl);
    else if (cl.Flag("--sync-phase")) {
      const std::string v = cl.Value();
      // below the cycle period, which the HAL configuration gives (checked there)
      o.robot.sync_phase_ns =
          v == "off" ? -1
                     : std::llround(1e3 * cl.NumberOf("--sync-phase", v, 0.0, kNoMax,
                                                      "microseconds >= 0, or off"));
    } else if (cl.Flag("--stall")) {
      const std::string v = cl.Value();
      const std::vector<std::string> p = Split(v, ':');
      if (p.size() != 2) cl.BadValue("T:MS (simulated seconds, wall milliseconds)", v);
      o.stalls.emplace_back(cl.NumberOf("--stall T", p[0], 0.0, kNoMax, "simulated seconds >= 0"),
                            cl.NumberOf("--stall MS", p[1], 0.0, 10000.0));
    } else if (cl.Flag("--quiet")) o.quiet = true;
    else cl.Unknown();
  }
  o.robot.profile = plant.Profile();
  return o;
}

/// The default virtual bus of bus `index` named `name`: lf, rf, lh, rh → udp::43101..43104.
std::string DefaultSpec(const std::string& name, std::size_t index) {
  static const char* const kLegs[] = {"lf", "rf", "lh", "rh"};
  for (int i = 0; i < 4; ++i)
    if (name == kLegs[i]) return "udp::" + std::to_string(43101 + i);
  return "udp::" + std::to_string(43101 + index);
}

double WallS() { return 1e-9 * static_cast<double>(hyq::MonotonicNs()); }

std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop = true; }

/// Publishes hyq-sim's truth on LCM from its own thread: the stepping thread only copies the
/// latest message into a slot (try-locked, a copy of ~500 bytes); a message not yet
/// published when the next one comes is replaced (the newest wins, the viewer wants the present).
class TruthPublisher {
 public:
  explicit TruthPublisher(const std::string& url) : lcm_(url) {
    if (!lcm_.good()) throw std::runtime_error("--lcm-truth: cannot open LCM on '" + url + "'");
    thread_ = std::thread([this] { Loop(); });
  }
  ~TruthPublisher() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_one();
    thread_.join();
  }
  /// Never waits: the stepping thread (SCHED_FIFO in real time) skips this message when the
  /// publisher holds the slot, rather than wait behind a SCHED_OTHER thread.
  void Offer(const hyq_lcm::lcmt_hyq_sim_truth& msg) {
    {
      std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
      if (!lock.owns_lock()) return;
      slot_ = msg;
      pending_ = true;
    }
    wake_.notify_one();
  }
  std::uint64_t published() const { return published_; }

 private:
  void Loop() {
    hyq_lcm::lcmt_hyq_sim_truth msg;
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [this] { return pending_ || stop_; });
        if (!pending_) return;  // stopping, nothing owed
        msg = slot_;
        pending_ = false;
      }
      if (lcm_.publish(kTruthChannel, &msg) == 0) ++published_;
    }
  }

  lcm::LCM lcm_;
  std::mutex mutex_;
  std::condition_variable wake_;
  hyq_lcm::lcmt_hyq_sim_truth slot_{};
  bool pending_ = false, stop_ = false;
  std::atomic<std::uint64_t> published_{0};
  std::thread thread_;
};

/// The plant's state as an lcmt_hyq_sim_truth.
void FillTruth(const hyq::sim::SimulatedRobot& r, hyq_lcm::lcmt_hyq_sim_truth* m) {
  const hyq::dynamics::VectorQ q = r.plant().q();
  const hyq::dynamics::VectorV v = r.plant().v();
  m->sim_time_s = r.time_s();
  m->utime = static_cast<std::int64_t>(std::llround(r.time_s() * 1e6));
  m->step = static_cast<std::int64_t>(r.counters().steps);
  for (int i = 0; i < 3; ++i) m->position_m[i] = q(i);
  for (int i = 0; i < 4; ++i) m->orientation_wxyz[i] = q(3 + i);
  for (int i = 0; i < 3; ++i) m->velocity_m_s[i] = v(i);
  for (int i = 0; i < 3; ++i) m->angular_velocity_rad_s[i] = v(3 + i);
  for (int j = 0; j < hyq::hal::kNumJoints; ++j) m->q_rad[j] = q(7 + j);
  int f = 0;
  for (const hyq::sim::FootContact& c : r.plant().FootContacts()) {
    if (f >= 4) break;
    m->contact_force_N[f][0] = c.force_W.x();
    m->contact_force_N[f][1] = c.force_W.y();
    m->contact_force_N[f][2] = c.force_W.z();
    m->touching[f] = c.touching ? 1 : 0;
    m->mu[f] = r.plant().foot_friction(f);
    ++f;
  }
  m->holding = r.holding() ? 1 : 0;
}

/// The HAL configuration, checked against the command line's buses and SYNC phase.
hyq::hal::HalConfig LoadConfig(const hyq::cli::CommandLine& cl, const Options& o) {
  using namespace hyq;
  hal::HalConfig cfg = config::LoadHalConfig(o.config);
  for (const auto& [bus, spec] : o.interfaces) {
    bool found = false;
    for (const hal::BusConfig& b : cfg.buses) found = found || b.name == bus;
    if (!found) cl.Bad("--interface", "a bus of " + o.config, bus);
  }
  if (o.robot.sync_phase_ns >= std::llround(1e9 * cfg.timing.cycle_period_s))
    cl.Bad("--sync-phase", "microseconds below the cycle period of " + o.config + " (" +
                               std::to_string(std::llround(1e6 * cfg.timing.cycle_period_s)) + " µs)",
           std::to_string(o.robot.sync_phase_ns / 1000));
  return cfg;
}

/// --write-model: the plant's model as MuJoCo gets it, the nominal URDF with the profile's model
/// error.
int WriteModel(const Options& o, const hyq::hal::HalConfig& cfg, const hyq::dynamics::Model& model) {
  using namespace hyq;
  sim::PlantConfig pc = o.robot.plant;
  pc.timestep_s = cfg.timing.cycle_period_s;
  pc.imu_sensor = true;
  o.robot.profile.ApplyTo(&pc);
  const sim::Plant plant(model, pc);
  std::ofstream f(o.write_model);
  if (!(f << plant.mjcf())) throw std::runtime_error("--write-model: cannot write '" + o.write_model + "'");
  if (!o.quiet)
    std::fprintf(stderr, "%s: wrote the %s plant's model (%.3f kg) to %s\n", kTool,
                 o.robot.profile.name.c_str(), sim::PerturbModel(model, pc.model_error).TotalMass(),
                 o.write_model.c_str());
  return 0;
}

/// One CAN channel per configured bus (the device side): --interface's, or the default virtual
/// bus.
struct Channels {
  std::vector<std::unique_ptr<hyq::hal::CanChannel>> owned;
  std::vector<hyq::hal::CanChannel*> raw;
};
Channels OpenChannels(const Options& o, const hyq::hal::HalConfig& cfg) {
  Channels c;
  for (std::size_t b = 0; b < cfg.buses.size(); ++b) {
    const auto it = o.interfaces.find(cfg.buses[b].name);
    const std::string spec = it != o.interfaces.end() ? hyq::drivers::SpecForInterface(it->second)
                                                      : DefaultSpec(cfg.buses[b].name, b);
    c.owned.push_back(hyq::drivers::OpenChannel(spec));
    c.raw.push_back(c.owned.back().get());
    if (!o.quiet) std::fprintf(stderr, "%s: bus %-3s on %s\n", kTool, cfg.buses[b].name.c_str(), spec.c_str());
  }
  return c;
}

/// What every step records: the truth (CSV and LCM), the injected stalls of the stepping thread,
/// the progress lines, and the wall-clock times the speed is measured from.
class StepRecorder {
 public:
  explicit StepRecorder(const Options& o) : o_(o), stalled_(o.stalls.size(), false) {
    if (!o.truth.empty()) {
      truth_.open(o.truth);
      if (!truth_) throw std::runtime_error("--truth: cannot write '" + o.truth + "'");
      truth_.precision(9);
      truth_ << "t,x,y,z,qw,qx,qy,qz";
      for (const char* p : {"q_", "qd_", "tau_"})
        for (int j = 0; j < hyq::hal::kNumJoints; ++j) truth_ << ',' << p << hyq::hal::JointName(j);
      for (const char* leg : {"lf", "rf", "lh", "rh"})
        truth_ << ',' << leg << "_fx," << leg << "_fy," << leg << "_fz," << leg << "_touching";
      truth_ << ",body_touching,holding";
      for (const char* leg : {"lf", "rf", "lh", "rh"}) truth_ << ',' << leg << "_mu";
      // the base's velocity: linear in W, angular in B (MuJoCo's free joint, HYQ_SIM_TRUTH's)
      truth_ << ",vx_W,vy_W,vz_W,wx_B,wy_B,wz_B";
      truth_ << '\n';
    }
    if (!o.lcm_truth_url.empty()) truth_lcm_ = std::make_unique<TruthPublisher>(o.lcm_truth_url);
  }

  void OnStep(const hyq::sim::SimulatedRobot& r) {
    Stall(r);
    last_step_wall_ = WallS();
    if (r.counters().steps == 1) first_step_wall_ = last_step_wall_;
    if (release_wall_ == 0 && !r.holding()) {
      release_wall_ = last_step_wall_;
      release_t_ = r.time_s();
    }
    if (truth_.is_open() && r.counters().steps % static_cast<std::uint64_t>(o_.truth_every) == 0)
      WriteTruthRow(r);
    if (truth_lcm_ && r.counters().steps % static_cast<std::uint64_t>(o_.lcm_truth_every) == 0) {
      FillTruth(r, &truth_msg_);
      truth_lcm_->Offer(truth_msg_);
    }
    if (!o_.quiet && r.time_s() + 1e-9 >= next_progress_) {
      next_progress_ += 1.0;
      const double wall = last_step_wall_ - first_step_wall_;
      std::fprintf(stderr, "%s: t %.1f s, base z %.3f m%s%s, %.2fx real time\n", kTool,
                   r.time_s(), r.plant().q()(2), r.holding() ? ", held" : "",
                   r.fell() ? ", FELL" : "", wall > 0 ? r.time_s() / wall : 0.0);
    }
  }

  /// Closes the truth file and stops the LCM publisher; returns the messages it published.
  std::uint64_t Finish() {
    if (truth_.is_open()) truth_.close();
    const std::uint64_t published = truth_lcm_ ? truth_lcm_->published() : 0;
    truth_lcm_.reset();
    return published;
  }

  double stepping_wall_s() const { return last_step_wall_ - first_step_wall_; }
  double released_at_s() const { return release_t_; }
  /// Simulated over wall time since the release (0: never released).
  double SpeedAfterRelease(double time_s) const {
    return last_step_wall_ > release_wall_ && release_wall_ > 0
               ? (time_s - release_t_) / (last_step_wall_ - release_wall_)
               : 0.0;
  }

 private:
  // --stall: the stepping thread stops, as on a preempted core
  void Stall(const hyq::sim::SimulatedRobot& r) {
    for (std::size_t i = 0; i < o_.stalls.size(); ++i)
      if (!stalled_[i] && r.time_s() + 1e-9 >= o_.stalls[i].first) {
        stalled_[i] = true;
        const auto ns = static_cast<long long>(o_.stalls[i].second * 1e6);
        const timespec d{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
        nanosleep(&d, nullptr);
      }
  }

  void WriteTruthRow(const hyq::sim::SimulatedRobot& r) {
    const hyq::dynamics::VectorQ q = r.plant().q();
    const hyq::dynamics::VectorV v = r.plant().v();
    truth_ << r.time_s();
    for (int i = 0; i < 7; ++i) truth_ << ',' << q(i);
    for (int j = 0; j < hyq::hal::kNumJoints; ++j) truth_ << ',' << q(7 + j);
    for (int j = 0; j < hyq::hal::kNumJoints; ++j) truth_ << ',' << v(6 + j);
    for (int j = 0; j < hyq::hal::kNumJoints; ++j) truth_ << ',' << r.applied_torque_Nm()(j);
    for (const hyq::sim::FootContact& c : r.plant().FootContacts())
      truth_ << ',' << c.force_W.x() << ',' << c.force_W.y() << ',' << c.force_W.z() << ','
             << (c.touching ? 1 : 0);
    truth_ << ',' << (r.plant().BodyTouchesGround() ? 1 : 0) << ',' << (r.holding() ? 1 : 0);
    for (int f = 0; f < 4; ++f) truth_ << ',' << r.plant().foot_friction(f);
    for (int i = 0; i < 6; ++i) truth_ << ',' << v(i);
    truth_ << '\n';
  }

  const Options& o_;
  std::ofstream truth_;
  std::unique_ptr<TruthPublisher> truth_lcm_;
  hyq_lcm::lcmt_hyq_sim_truth truth_msg_{};
  double first_step_wall_ = 0, last_step_wall_ = 0, release_wall_ = 0, release_t_ = 0;
  double next_progress_ = 1.0;
  std::vector<bool> stalled_;
};

/// Real time: the stepping thread's and the bus thread's scheduling, as asked and as obtained.
struct Threads {
  hyq::servo::RealtimeReport stepping, bus;
  hyq::servo::RealtimeConfig stepping_cfg, bus_cfg;
  cpu_set_t all_cpus;
  bool have_cpus = false;
};

/// The bus thread's CPU, resolved before the stepping thread pins itself (a thread inherits its
/// creator's affinity: unpinned, it gets the process's whole set back); then the stepping
/// thread's SCHED_FIFO, CPU and memory lock (real time with --rt-priority).
void SetUpSteppingThread(const Options& o, Threads* t) {
  using namespace hyq;
  CPU_ZERO(&t->all_cpus);
  t->have_cpus = sched_getaffinity(0, sizeof t->all_cpus, &t->all_cpus) == 0;
  t->bus_cfg.cpu = servo::ResolveCpu(o.bus_cpu, true, -1);
  if (o.lockstep || o.rt_priority <= 0) return;
  t->stepping_cfg.priority = o.rt_priority;
  t->stepping_cfg.cpu = servo::ResolveCpu(o.cpu, true, 0);
  t->stepping = servo::SetUpRealtimeThread(t->stepping_cfg);
  for (const std::string& w : t->stepping.warnings) std::fprintf(stderr, "%s: warning: %s\n", kTool, w.c_str());
  if (!o.quiet)
    std::fprintf(stderr, "%s: stepping thread %s, %s, memory %s\n", kTool,
                 t->stepping.fifo ? ("SCHED_FIFO " + std::to_string(t->stepping_cfg.priority)).c_str()
                                  : "SCHED_OTHER",
                 t->stepping.pinned ? ("on CPU " + std::to_string(t->stepping_cfg.cpu)).c_str()
                                    : "not pinned",
                 t->stepping.locked ? "locked" : "not locked");
}

/// The bus thread's set-up, run first on that thread: its CPU (the process's whole set when
/// none), and SCHED_FIFO with --bus-priority.
hyq::sim::BusThreadConfig BusThread(const Options& o, Threads* t) {
  using namespace hyq;
  sim::BusThreadConfig bus;
  bus.enabled = o.bus_thread;
  bus.setup = [&o, t] {
    if (t->bus_cfg.cpu == servo::kNoCpu && t->have_cpus)
      (void)sched_setaffinity(0, sizeof t->all_cpus, &t->all_cpus);
    if (o.bus_priority <= 0) {
      if (t->bus_cfg.cpu != servo::kNoCpu) {
        cpu_set_t one;
        CPU_ZERO(&one);
        CPU_SET(t->bus_cfg.cpu, &one);
        t->bus.pinned = sched_setaffinity(0, sizeof one, &one) == 0;
      }
      return;
    }
    t->bus_cfg.priority = o.bus_priority;
    t->bus_cfg.prefault_stack_kib = 64;
    t->bus = servo::SetUpRealtimeThread(t->bus_cfg);
    for (const std::string& w : t->bus.warnings)
      std::fprintf(stderr, "%s: warning: bus thread: %s\n", kTool, w.c_str());
    if (!o.quiet)
      std::fprintf(stderr, "%s: bus thread %s, %s\n", kTool,
                   t->bus.fifo ? ("SCHED_FIFO " + std::to_string(t->bus_cfg.priority)).c_str() : "SCHED_OTHER",
                   t->bus.pinned ? ("on CPU " + std::to_string(t->bus_cfg.cpu)).c_str() : "not pinned");
  };
  return bus;
}

Json Histogram(const hyq::hal::LatencyHistogram& h) {
  return {{"count", h.count()},
          {"p50_us", 1e-3 * static_cast<double>(h.Percentile(0.5))},
          {"p99_us", 1e-3 * static_cast<double>(h.Percentile(0.99))},
          {"p999_us", 1e-3 * static_cast<double>(h.Percentile(0.999))},
          {"max_us", 1e-3 * static_cast<double>(h.max_ns())}};
}

/// The boards at exit: their set-points, and whether they tripped on their own timer (a silent
/// master) and how long after the last SYNC / set-point.
void AddBoards(const hyq::hal::Emulator& e, Json* s) {
  int tripped = 0;
  double max_trip_delay_ms = 0.0, max_abs_setpoint_Nm = 0.0;
  Json boards = Json::array();
  for (int j = 0; j < hyq::hal::kNumJoints; ++j) {
    const bool trip = e.setpoint_trip_ns(j) >= 0;
    const double delay_ms = 1e-6 * static_cast<double>(e.setpoint_trip_delay_ns(j));
    tripped += trip ? 1 : 0;
    if (trip) max_trip_delay_ms = std::max(max_trip_delay_ms, delay_ms);
    max_abs_setpoint_Nm = std::max(max_abs_setpoint_Nm, std::abs(e.torque_setpoint_Nm(j)));
    boards.push_back({{"joint", std::string(hyq::hal::JointName(j))},
                      {"setpoint_Nm", e.torque_setpoint_Nm(j)},
                      {"outputs_enabled", e.outputs_enabled(j)},
                      {"tripped", trip},
                      {"trip_delay_ms", trip ? delay_ms : 0.0}});
  }
  (*s)["boards"] = std::move(boards);
  (*s)["boards_tripped"] = tripped;
  (*s)["max_trip_delay_ms"] = max_trip_delay_ms;
  (*s)["max_abs_setpoint_Nm"] = max_abs_setpoint_Nm;
}

/// Devices reset (--fault T:reset:...), on every bus.
std::uint64_t BoardResets(const hyq::hal::Emulator& e, const hyq::hal::HalConfig& cfg) {
  std::uint64_t n = 0;
  for (std::size_t b = 0; b < cfg.buses.size(); ++b) n += e.counters(static_cast<int>(b)).resets;
  return n;
}

/// Where a lock-step run's wall time went, per step: waiting for the master (its cycle and the
/// transport's hand-off), the bus work, the physics step, the truth recording, and the rest
/// (the loop itself, stalls). Empty in real time.
Json LockstepWall(const hyq::sim::LockstepTime& t, bool lockstep) {
  if (!lockstep || t.steps == 0) return Json::object();
  const double n = static_cast<double>(t.steps);
  const auto us = [n](std::int64_t ns) { return 1e-3 * static_cast<double>(ns) / n; };
  const double total_us = us(t.loop_ns);
  const double known = us(t.wait_ns) + us(t.bus_ns) + us(t.step_ns);
  return {{"per_step_us", total_us},
          {"waiting_for_master_us", us(t.wait_ns)},
          {"bus_us", us(t.bus_ns)},
          {"plant_step_us", us(t.step_ns - t.observer_ns)},
          {"truth_recording_us", us(t.observer_ns)},
          {"other_us", std::max(0.0, total_us - known)},
          {"waits_per_step", static_cast<double>(t.waits) / n},
          {"steps", t.steps}};
}

/// --summary: the run's outcome, counters, timing and the boards' state, as JSON (read by
/// scripts/hil.sh, tests/hil/*.sh and scripts/*.py).
Json Summary(const Options& o, const hyq::hal::HalConfig& cfg,
                       hyq::sim::SimulatedRobot& robot, const hyq::sim::RealtimeRunner& runner,
                       const StepRecorder& recorder, const Threads& t, double wall_s,
                       std::uint64_t truth_published) {
  using namespace hyq;
  const auto& c = robot.counters();
  // the boards' SYNCs left unanswered because a newer one waited (real time, behind)
  std::uint64_t superseded_syncs = 0;
  for (std::size_t b = 0; b < cfg.buses.size(); ++b)
    superseded_syncs += robot.emulator().counters(static_cast<int>(b)).superseded_syncs;
  const double stepping_wall = recorder.stepping_wall_s();
  Json syncs = Json::object();
  for (std::size_t b = 0; b < cfg.buses.size(); ++b) syncs[cfg.buses[b].name] = c.syncs[b];
  Json boxes = Json::array();
  for (const sim::GroundBox& b : o.robot.plant.boxes)
    boxes.push_back({{"x0_m", b.x0_m}, {"x1_m", b.x1_m}, {"y0_m", b.y0_m}, {"y1_m", b.y1_m},
                     {"height_m", b.height_m}});
  Json s = {
      {"mode", o.lockstep ? "lockstep" : "realtime"},
      {"profile", Json::parse(o.robot.profile.Json())},
      {"boxes", std::move(boxes)},
      {"imu_bias_B", {{"gyro_rad_s", {robot.gyro_bias_B().x(), robot.gyro_bias_B().y(), robot.gyro_bias_B().z()}},
                      {"accel_m_s2", {robot.accel_bias_B().x(), robot.accel_bias_B().y(), robot.accel_bias_B().z()}}}},
      {"simulated_time_s", robot.time_s()},
      {"steps", c.steps},
      {"held_steps", c.held_steps},
      {"fell", robot.fell()},
      {"fell_at_s", robot.fell() ? robot.fell_at_s() : 0.0},
      {"min_base_height_m", robot.min_base_height_m()},
      {"max_descent_speed_m_s", robot.max_descent_speed_m_s()},
      {"sat_down", robot.sat_down()},
      {"sat_down_at_s", robot.sat_down() ? robot.sat_down_at_s() : 0.0},
      {"contact_speed_m_s", robot.contact_speed_m_s()},
      {"contact_tilt_deg", robot.contact_tilt_deg()},
      {"syncs_per_bus", std::move(syncs)},
      {"wall_s", wall_s},
      {"stepping_wall_s", stepping_wall},
      {"speed", stepping_wall > 0 ? robot.time_s() / stepping_wall : 0.0},
      {"released_at_s", recorder.released_at_s()},
      {"speed_after_release", recorder.SpeedAfterRelease(robot.time_s())},
      {"lockstep_forced_steps", c.lockstep_forced},
      {"lockstep_wall", LockstepWall(robot.lockstep_time(), o.lockstep)},
      {"realtime_overruns", runner.counters().overruns},
      {"late_steps", runner.counters().late_steps},
      {"dropped_steps", runner.counters().dropped_steps},
      {"stale_answers", runner.bus().stale_answers()},
      {"superseded_syncs", superseded_syncs},
      {"step_lateness", Histogram(runner.step_lateness())},
      {"step_time", Histogram(runner.step_time())},
      {"bus_gap", Histogram(runner.bus().gap())},
      {"bus_poll_time", Histogram(runner.bus().poll_time())},
      {"sync_phase_us", o.robot.sync_phase_ns >= 0
                            ? Json(1e-3 * static_cast<double>(o.robot.sync_phase_ns))
                            : Json(nullptr)},
      {"sync_phase_error", Histogram(runner.sync_phase_error())},
      {"stepping_thread", {{"fifo", t.stepping.fifo},
                           {"priority", t.stepping.fifo ? t.stepping_cfg.priority : 0},
                           {"cpu", t.stepping.pinned ? t.stepping_cfg.cpu : -1},
                           {"memory_locked", t.stepping.locked}}},
      {"bus_thread", {{"enabled", !o.lockstep && o.bus_thread},
                      {"fifo", t.bus.fifo},
                      {"priority", t.bus.fifo ? t.bus_cfg.priority : 0},
                      {"cpu", t.bus.pinned ? t.bus_cfg.cpu : -1}}},
      {"stalls", o.stalls.size()},
      {"faults_injected", c.faults_injected},
      {"stalled_steps", c.stalled_steps},
      {"board_resets", BoardResets(robot.emulator(), cfg)},
      {"lcm_truth_published", truth_published}};
  AddBoards(robot.emulator(), &s);
  Json faults = Json::array();
  for (const sim::FaultSpec& f : robot.faults())
    faults.push_back({{"spec", f.text}, {"t_s", f.t_s}, {"kind", sim::ToString(f.kind)},
                      {"injected", robot.time_s() + 1e-9 >= f.t_s}});
  s["faults"] = std::move(faults);
  return s;
}

int Run(const hyq::cli::CommandLine& cl, const Options& o) {
  using namespace hyq;
  const hal::HalConfig cfg = LoadConfig(cl, o);
  std::vector<sim::FaultSpec> faults;
  for (const std::string& f : o.faults) {
    try {
      faults.push_back(sim::ParseFaultSpec(f, cfg));
    } catch (const std::invalid_argument& e) {
      cl.Fail(std::string("--fault: ") + e.what());
    }
    // in real time a stalled daemon is the daemon's own doing (hyq-servod --inject-overrun)
    if (faults.back().kind == sim::FaultSpec::Kind::kStall && !o.lockstep)
      cl.Fail("--fault: fault '" + f + "': expected --mode lockstep for stall, found realtime");
  }
  const dynamics::Model model = dynamics::LoadModelFromUrdf(o.urdf);
  if (!o.write_model.empty()) return WriteModel(o, cfg, model);
  const Channels channels = OpenChannels(o, cfg);
  sim::SimulatedRobot robot(model, cfg, channels.raw, o.robot);
  if (!o.quiet && o.robot.profile.name != "ideal")
    std::fprintf(stderr, "%s: plant profile %s\n", kTool, o.robot.profile.Json().c_str());
  for (const sim::FaultSpec& f : faults) robot.ScheduleFault(f);
  StepRecorder recorder(o);
  robot.SetStepObserver([&recorder](const sim::SimulatedRobot& r) { recorder.OnStep(r); });

  signal(SIGINT, OnSignal);
  signal(SIGTERM, OnSignal);
  Threads threads;
  SetUpSteppingThread(o, &threads);
  const double start_wall = WallS();
  sim::RealtimeRunner runner(&robot);
  if (o.lockstep) (void)robot.RunLockStep(g_stop, o.duration_s);
  else (void)runner.Run(g_stop, o.duration_s, BusThread(o, &threads));
  const double wall_s = WallS() - start_wall;
  const std::uint64_t truth_published = recorder.Finish();

  if (!o.summary.empty()) {
    std::ofstream s(o.summary);
    if (!s) throw std::runtime_error("--summary: cannot write '" + o.summary + "'");
    s << Summary(o, cfg, robot, runner, recorder, threads, wall_s, truth_published).dump(2) << '\n';
  }
  if (!o.quiet) {
    const double stepping_wall = recorder.stepping_wall_s();
    std::fprintf(stderr, "%s: %.3f simulated s in %llu steps, %s, min base height %.3f m, %.2fx real time\n",
                 kTool, robot.time_s(), static_cast<unsigned long long>(robot.counters().steps),
                 robot.fell() ? "fell" : robot.sat_down() ? "sat down" : "did not fall",
                 robot.min_base_height_m(), stepping_wall > 0 ? robot.time_s() / stepping_wall : 0.0);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  hyq::cli::CommandLine cl(argc, argv, kTool, hyq::cli::WithPaths(Help()));
  const Options o = Parse(cl);
  return hyq::cli::Run(kTool, [&] { return Run(cl, o); });
}
