#include "config/servo_config_loader.h"

// GCC 12 warns falsely (-Wrestrict, bug 105329) on std::string operator+ chains at -O3; the
// messages here are built that way for readability.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wrestrict"
#endif

#include <yaml-cpp/yaml.h>

#include <array>
#include <cmath>
#include <string>

#include "config/hal_config_loader.h"
#include "config/yaml_reader.h"
#include "hal/config_error.h"
#include "servo/command/command_channel.h"
#include "servo/telemetry/lcm_url.h"

namespace hyq::config {
namespace {

using detail::Describe;
using detail::Reader;
using hal::ConfigError;

// Upper bounds on the gains: beyond them the discrete loop at 1 kHz on HyQ's lightest joint
// (HAA of a leg in the air, ≈ 0.3 kg·m² reflected) would not be stable, or the numbers are
// typing errors (docs/servo.md, "Gains").
constexpr double kMaxKpTau = 5000.0;  // N·m/rad
constexpr double kMaxKdTau = 200.0;   // N·m·s/rad
constexpr double kMaxKiTau = 5000.0;  // N·m/(rad·s)

std::string Path(const std::string& path, const char* key) { return Reader::Join(path, key); }

// One value per joint: one number (all joints), three (haa, hfe, kfe of every leg) or twelve.
dynamics::VectorJ PerJoint(const Reader& r, const YAML::Node& map, const std::string& path,
                           const char* key, double lo, double hi, const char* unit) {
  const YAML::Node n = map[key];
  const std::string p = Path(path, key);
  const std::string range = "[" + detail::FormatNumber(lo) + ", " + detail::FormatNumber(hi) + "] " + unit;
  dynamics::VectorJ v;
  auto check = [&](const YAML::Node& e, const std::string& ep) {
    const double x = r.ToNumber(e, ep);
    if (x < lo || x > hi) r.Fail(e, ep, "a value in " + range, Describe(e));
    return x;
  };
  if (n.IsScalar()) {
    v.setConstant(check(n, p));
  } else if (n.IsSequence() && n.size() == 3) {
    for (int j = 0; j < 12; ++j)
      v(j) = check(n[static_cast<std::size_t>(j % 3)], p + "[" + std::to_string(j % 3) + "]");
  } else if (n.IsSequence() && n.size() == 12) {
    for (int j = 0; j < 12; ++j)
      v(j) = check(n[static_cast<std::size_t>(j)], p + "[" + std::to_string(j) + "]");
  } else {
    r.Fail(n, p,
           "one number, 3 numbers (haa, hfe, kfe of every leg) or 12 numbers (lf, rf, lh, rh x "
           "haa, hfe, kfe)",
           Describe(n));
  }
  return v;
}

std::array<double, 4> PerFoot(const Reader& r, const YAML::Node& map, const std::string& path,
                              const char* key, double lo, double hi) {
  const YAML::Node n = map[key];
  const std::string p = Path(path, key);
  std::array<double, 4> v{};
  const std::string range = "a friction coefficient in [" + detail::FormatNumber(lo) + ", " +
                            detail::FormatNumber(hi) + "]";
  auto check = [&](const YAML::Node& e, const std::string& ep) {
    const double x = r.ToNumber(e, ep);
    if (x < lo || x > hi) r.Fail(e, ep, range, Describe(e));
    return x;
  };
  if (n.IsScalar()) {
    v.fill(check(n, p));
  } else if (n.IsSequence() && n.size() == 4) {
    for (std::size_t f = 0; f < 4; ++f) v[f] = check(n[f], p + "[" + std::to_string(f) + "]");
  } else {
    r.Fail(n, p, "one number or 4 numbers (lf, rf, lh, rh)", Describe(n));
  }
  return v;
}

double Bounded(const Reader& r, const YAML::Node& map, const std::string& path, const char* key,
               double d, double lo, double hi) {
  if (!map[key].IsDefined()) return d;
  const double x = r.Number(map, path, key);
  if (x < lo || x > hi)
    r.Fail(map[key], Path(path, key),
           "a number in [" + detail::FormatNumber(lo) + ", " + detail::FormatNumber(hi) + "]",
           Describe(map[key]));
  return x;
}

// Three numbers for the base velocity's axes: vx (m/s), vy (m/s), wz (rad/s), each in its range.
std::array<double, 3> VelocityAxes(const Reader& r, const YAML::Node& map, const std::string& path,
                                   const char* key, const std::array<double, 3>& d,
                                   const std::array<double, 3>& hi, const char* units) {
  const YAML::Node n = map[key];
  if (!n.IsDefined()) return d;
  const std::string p = Path(path, key);
  if (!n.IsSequence() || n.size() != 3)
    r.Fail(n, p, std::string("3 numbers [vx, vy, wz] in ") + units, Describe(n));
  std::array<double, 3> v{};
  for (std::size_t i = 0; i < 3; ++i) {
    const std::string ep = p + "[" + std::to_string(i) + "]";
    v[i] = r.ToNumber(n[i], ep);
    if (v[i] < 0.0 || v[i] > hi[i])
      r.Fail(n[i], ep, "a number in [0, " + detail::FormatNumber(hi[i]) + "]", Describe(n[i]));
  }
  return v;
}

int BoundedInt(const Reader& r, const YAML::Node& map, const std::string& path, const char* key,
               int d, int lo, int hi) {
  return map[key].IsDefined() ? static_cast<int>(r.Integer(map, path, key, lo, hi)) : d;
}

bool BoolOr(const Reader& r, const YAML::Node& map, const std::string& path, const char* key,
            bool d) {
  return map[key].IsDefined() ? r.Bool(map, path, key) : d;
}

std::string StringOr(const Reader& r, const YAML::Node& map, const std::string& path,
                     const char* key, const std::string& d) {
  return map[key].IsDefined() ? r.String(map, path, key) : d;
}

YAML::Node Section(const Reader& r, const YAML::Node& root, const char* key) {
  if (!root[key].IsDefined()) return YAML::Node(YAML::NodeType::Map);
  return r.Map(root, "", key);
}

std::string Resolve(const std::filesystem::path& base, const std::string& p) {
  const std::filesystem::path fp(p);
  return (fp.is_absolute() ? fp : base / fp).lexically_normal().string();
}

void ReadController(const Reader& r, const YAML::Node& root, servo::ServoConfig& c) {
  const YAML::Node n = Section(r, root, "controller");
  r.Keys(n, "controller", {"kind", "gains", "two_stage", "disturbance_observer"});
  auto& cc = c.controller;
  if (n["kind"].IsDefined()) {
    const std::string k = r.OneOf(n, "controller", "kind", {"pid", "noslip", "stage1", "two_stage", "pd_gravity"});
    cc.kind = *servo::ParseControllerKind(k);
  }
  if (n["gains"].IsDefined()) {
    const YAML::Node g = r.Map(n, "controller", "gains");
    const std::string gp = "controller.gains";
    r.Keys(g, gp, {"kp_tau", "kd_tau", "kp_acc", "kd_acc", "pid_kp", "pid_ki", "pid_kd",
                   "pid_i_limit", "pdg_kp", "pdg_kd", "ki_tau", "i_limit_tau", "swing_scale",
                   "pid_swing_scale", "pdg_swing_scale"});
    const double rate = c.rate_hz;
    if (g["kp_tau"].IsDefined()) cc.feedback.kp_tau = PerJoint(r, g, gp, "kp_tau", 0, kMaxKpTau, "N·m/rad");
    if (g["kd_tau"].IsDefined()) cc.feedback.kd_tau = PerJoint(r, g, gp, "kd_tau", 0, kMaxKdTau, "N·m·s/rad");
    // q̈ feedback: discrete stability at the loop rate needs kd·dt < 1 and kp·dt² < 1
    if (g["kp_acc"].IsDefined()) cc.feedback.kp_acc = PerJoint(r, g, gp, "kp_acc", 0, 0.25 * rate * rate, "1/s² (0.25/dt²)");
    if (g["kd_acc"].IsDefined()) cc.feedback.kd_acc = PerJoint(r, g, gp, "kd_acc", 0, 0.5 * rate, "1/s (0.5/dt)");
    if (g["pid_kp"].IsDefined()) cc.pid.kp = PerJoint(r, g, gp, "pid_kp", 0, kMaxKpTau, "N·m/rad");
    if (g["pid_ki"].IsDefined()) cc.pid.ki = PerJoint(r, g, gp, "pid_ki", 0, kMaxKiTau, "N·m/(rad·s)");
    if (g["pid_kd"].IsDefined()) cc.pid.kd = PerJoint(r, g, gp, "pid_kd", 0, kMaxKdTau, "N·m·s/rad");
    if (g["ki_tau"].IsDefined()) cc.feedback.ki_tau = PerJoint(r, g, gp, "ki_tau", 0, kMaxKiTau, "N·m/(rad·s)");
    if (g["i_limit_tau"].IsDefined()) cc.feedback.i_limit_tau = PerJoint(r, g, gp, "i_limit_tau", 0, 1000, "N·m");
    if (g["pdg_kp"].IsDefined()) cc.pd_gravity.kp = PerJoint(r, g, gp, "pdg_kp", 0, kMaxKpTau, "N·m/rad");
    if (g["pdg_kd"].IsDefined()) cc.pd_gravity.kd = PerJoint(r, g, gp, "pdg_kd", 0, kMaxKdTau, "N·m·s/rad");
    if (g["pid_i_limit"].IsDefined()) cc.pid.i_limit = PerJoint(r, g, gp, "pid_i_limit", 0, 1000, "N·m");
    cc.swing_gain_scale = Bounded(r, g, gp, "swing_scale", cc.swing_gain_scale, 0.05, 1.0);
    cc.pid_swing_gain_scale = Bounded(r, g, gp, "pid_swing_scale", cc.pid_swing_gain_scale, 0.05, 1.0);
    cc.pdg_swing_gain_scale = Bounded(r, g, gp, "pdg_swing_scale", cc.pdg_swing_gain_scale, 0.05, 1.0);
  }
  if (n["disturbance_observer"].IsDefined()) {
    const YAML::Node d = r.Map(n, "controller", "disturbance_observer");
    const std::string dp = "controller.disturbance_observer";
    r.Keys(d, dp, {"enabled", "bandwidth_hz", "max_force_N", "max_torque_Nm"});
    auto& o = c.disturbance;
    o.enabled = BoolOr(r, d, dp, "enabled", o.enabled);
    // the low-pass must stay well below the loop's Nyquist rate
    o.bandwidth_hz = Bounded(r, d, dp, "bandwidth_hz", o.bandwidth_hz, 0.05, 0.1 * c.rate_hz);
    o.max_force_N = Bounded(r, d, dp, "max_force_N", o.max_force_N, 0.0, 2000.0);
    o.max_torque_Nm = Bounded(r, d, dp, "max_torque_Nm", o.max_torque_Nm, 0.0, 1000.0);
  }
  if (n["two_stage"].IsDefined()) {
    const YAML::Node t = r.Map(n, "controller", "two_stage");
    const std::string tp = "controller.two_stage";
    r.Keys(t, tp, {"objective", "horizon_s", "project_contact_velocity", "max_iterations",
                   "stage2_max_iterations", "time_budget_us", "tangent_directions", "stage2",
                   "null_space_tolerance", "frictionless_mu", "optimal_set_tolerance",
                   "velocity_consistent_qdd"});
    auto& s = cc.id;
    if (t["objective"].IsDefined())
      s.objective = r.OneOf(t, tp, "objective", {"maximum_dissipation", "kinetic_energy"}) ==
                            "kinetic_energy"
                        ? servo::StageOneObjective::kKineticEnergy
                        : servo::StageOneObjective::kMaximumDissipation;
    s.horizon_s = Bounded(r, t, tp, "horizon_s", s.horizon_s, 0.0, 0.1);
    s.project_contact_velocity = BoolOr(r, t, tp, "project_contact_velocity", s.project_contact_velocity);
    s.velocity_consistent_qdd = BoolOr(r, t, tp, "velocity_consistent_qdd", s.velocity_consistent_qdd);
    s.max_iterations = BoundedInt(r, t, tp, "max_iterations", s.max_iterations, 10, 10000);
    s.stage2_max_iterations = BoundedInt(r, t, tp, "stage2_max_iterations", s.stage2_max_iterations, 10, 10000);
    s.tangent_directions = BoundedInt(r, t, tp, "tangent_directions", s.tangent_directions, 4, 4);
    s.stage2 = BoolOr(r, t, tp, "stage2", s.stage2);  // the stage1 kind turns it off regardless
    s.null_space_tolerance = Bounded(r, t, tp, "null_space_tolerance", s.null_space_tolerance, 1e-15, 1e-3);
    s.frictionless_mu = Bounded(r, t, tp, "frictionless_mu", s.frictionless_mu, 0.0, 0.01);
    // Stage II held in Stage I's optimal set (eq 9) with this rounding tolerance; 1 drops the row
    s.optimal_set_tolerance = Bounded(r, t, tp, "optimal_set_tolerance", s.optimal_set_tolerance, 0.0, 1.0);
    if (t["time_budget_us"].IsDefined())
      s.time_budget = std::chrono::nanoseconds(static_cast<std::int64_t>(
          1000.0 * Bounded(r, t, tp, "time_budget_us", 0.0, 10.0, 1e6)));
  }
}

void ReadReference(const Reader& r, const YAML::Node& root, servo::ServoConfig& c) {
  const YAML::Node n = Section(r, root, "reference");
  r.Keys(n, "reference", {"kind", "enable_ramp_s", "trot", "figure_eight"});
  if (n["kind"].IsDefined()) {
    const std::string k = r.OneOf(n, "reference", "kind", {"stand", "trot", "figure_eight"});
    c.reference = k == "trot"           ? servo::Reference::Kind::kTrot
                  : k == "figure_eight" ? servo::Reference::Kind::kFigureEight
                                        : servo::Reference::Kind::kStand;
  }
  c.enable_ramp_s = Bounded(r, n, "reference", "enable_ramp_s", c.enable_ramp_s, 0.0, 10.0);
  if (n["trot"].IsDefined()) {
    const YAML::Node t = r.Map(n, "reference", "trot");
    const std::string p = "reference.trot";
    r.Keys(t, p, {"step_frequency_Hz", "step_height_m", "stride_m", "duty_factor", "start_delay_s",
                  "ramp_s", "max_velocity", "max_acceleration"});
    auto& s = c.trot;
    s.step_frequency_Hz = Bounded(r, t, p, "step_frequency_Hz", s.step_frequency_Hz, 0.2, 4.0);
    s.step_height_m = Bounded(r, t, p, "step_height_m", s.step_height_m, 0.0, 0.2);
    s.stride_m = Bounded(r, t, p, "stride_m", s.stride_m, -0.4, 0.4);
    s.duty_factor = Bounded(r, t, p, "duty_factor", s.duty_factor, 0.5, 0.95);
    s.start_delay_s = Bounded(r, t, p, "start_delay_s", s.start_delay_s, 0.0, 60.0);
    s.ramp_s = Bounded(r, t, p, "ramp_s", s.ramp_s, 0.0, 60.0);
    s.max_velocity = VelocityAxes(r, t, p, "max_velocity", s.max_velocity, {1.0, 0.5, 1.5},
                                  "m/s, m/s, rad/s");
    s.max_acceleration = VelocityAxes(r, t, p, "max_acceleration", s.max_acceleration,
                                      {5.0, 5.0, 10.0}, "m/s², m/s², rad/s²");
    for (std::size_t i = 0; i < 3; ++i)
      if (!(s.max_acceleration[i] > 0.0))
        r.Fail(t["max_acceleration"][i], p + ".max_acceleration[" + std::to_string(i) + "]",
               "a number > 0", Describe(t["max_acceleration"][i]));
  }
  if (n["figure_eight"].IsDefined()) {
    const YAML::Node t = r.Map(n, "reference", "figure_eight");
    const std::string p = "reference.figure_eight";
    r.Keys(t, p, {"period_s", "amplitude_x_m", "amplitude_y_m", "start_delay_s", "ramp_s"});
    auto& s = c.figure_eight;
    s.period_s = Bounded(r, t, p, "period_s", s.period_s, 0.5, 60.0);
    s.amplitude_x_m = Bounded(r, t, p, "amplitude_x_m", s.amplitude_x_m, 0.0, 0.15);
    s.amplitude_y_m = Bounded(r, t, p, "amplitude_y_m", s.amplitude_y_m, 0.0, 0.15);
    s.start_delay_s = Bounded(r, t, p, "start_delay_s", s.start_delay_s, 0.0, 60.0);
    s.ramp_s = Bounded(r, t, p, "ramp_s", s.ramp_s, 0.0, 60.0);
  }
}

void ReadRest(const Reader& r, const YAML::Node& root, const std::filesystem::path& base_dir,
              servo::ServoConfig& c) {
  {
    const YAML::Node n = Section(r, root, "realtime");
    const std::string p = "realtime";
    r.Keys(n, p, {"enabled", "priority", "cpu", "lock_memory", "prefault_stack_kib"});
    auto& s = c.realtime;
    s.enabled = BoolOr(r, n, p, "enabled", s.enabled);
    s.priority = BoundedInt(r, n, p, "priority", s.priority, 1, 99);
    if (n["cpu"].IsDefined() && n["cpu"].IsScalar() && n["cpu"].Scalar() == "auto") {
      s.cpu = servo::kAutoCpu;  // where two cores exist (servo::ResolveCpu)
    } else if (n["cpu"].IsDefined()) {
      try {
        s.cpu = BoundedInt(r, n, p, "cpu", s.cpu, -1, 1023);
      } catch (const hal::ConfigError&) {
        r.Fail(n["cpu"], "realtime.cpu", "an integer in [-1, 1023] or 'auto'",
               n["cpu"].IsScalar() ? "'" + n["cpu"].Scalar() + "'" : std::string("a non-scalar"));
      }
    }
    s.lock_memory = BoolOr(r, n, p, "lock_memory", s.lock_memory);
    s.prefault_stack_kib = static_cast<std::uint32_t>(
        BoundedInt(r, n, p, "prefault_stack_kib", static_cast<int>(s.prefault_stack_kib), 0, 8192));
  }
  {
    const YAML::Node n = Section(r, root, "deadline");
    const std::string p = "deadline";
    r.Keys(n, p, {"budget_fraction", "max_consecutive_misses", "stop_in_lockstep"});
    c.deadline.budget_fraction = Bounded(r, n, p, "budget_fraction", c.deadline.budget_fraction, 0.05, 1.0);
    c.deadline.max_consecutive_misses =
        BoundedInt(r, n, p, "max_consecutive_misses", c.deadline.max_consecutive_misses, 1, 1000);
    c.deadline.stop_in_lockstep = BoolOr(r, n, p, "stop_in_lockstep", c.deadline.stop_in_lockstep);
  }
  {
    const YAML::Node n = Section(r, root, "safety");
    const std::string p = "safety";
    // the safety layer's own tolerance for missing inputs is gone: one policy, the HAL's (#17)
    if (n["max_missing_cycles"].IsDefined())
      r.Fail(n["max_missing_cycles"], "safety.max_missing_cycles",
             "no such key: a late or missing input is held for up to timing.max_held_cycles "
             "of the HAL file (robot.hal) and the next one is a fault; set it there",
             "the key, which the safety layer no longer has");
    r.Keys(n, p, {"position_margin_rad", "max_velocity_rad_s", "max_position_jump_rad",
                  "max_measured_torque_Nm", "max_gyro_rad_s", "max_accel_m_s2",
                  "max_tilt_rad", "damping_Nms_per_rad", "damping_duration_s",
                  "damp_on_bad_command"});
    auto& s = c.safety;
    s.position_margin_rad = Bounded(r, n, p, "position_margin_rad", s.position_margin_rad, 0.0, 1.0);
    s.max_velocity_rad_s = Bounded(r, n, p, "max_velocity_rad_s", s.max_velocity_rad_s, 0.1, 100.0);
    s.max_position_jump_rad = Bounded(r, n, p, "max_position_jump_rad", s.max_position_jump_rad, 1e-4, 1.0);
    s.max_measured_torque_Nm = Bounded(r, n, p, "max_measured_torque_Nm", s.max_measured_torque_Nm, 1.0, 1e5);
    s.max_gyro_rad_s = Bounded(r, n, p, "max_gyro_rad_s", s.max_gyro_rad_s, 0.1, 100.0);
    s.max_accel_m_s2 = Bounded(r, n, p, "max_accel_m_s2", s.max_accel_m_s2, 1.0, 1e4);
    s.max_tilt_rad = Bounded(r, n, p, "max_tilt_rad", s.max_tilt_rad, 0.05, 3.2);
    s.damping_Nms_per_rad = Bounded(r, n, p, "damping_Nms_per_rad", s.damping_Nms_per_rad, 0.0, kMaxKdTau);
    s.damping_duration_s = Bounded(r, n, p, "damping_duration_s", s.damping_duration_s, 0.0, 60.0);
    s.damp_on_bad_command = BoolOr(r, n, p, "damp_on_bad_command", s.damp_on_bad_command);
  }
  {
    const YAML::Node n = Section(r, root, "estimator");
    const std::string p = "estimator";
    r.Keys(n, p, {"stance_force_N", "tilt_correction_gain", "velocity_blend",
                  "imu_gravity_window_m_s2"});
    auto& s = c.estimator;
    s.stance_force_N = Bounded(r, n, p, "stance_force_N", s.stance_force_N, 0.0, 2000.0);
    s.tilt_correction_gain = Bounded(r, n, p, "tilt_correction_gain", s.tilt_correction_gain, 0.0, 100.0);
    s.velocity_blend = Bounded(r, n, p, "velocity_blend", s.velocity_blend, 0.0, 1.0);
    s.imu_gravity_window_m_s2 = Bounded(r, n, p, "imu_gravity_window_m_s2", s.imu_gravity_window_m_s2, 0.0, 9.81);
  }
  {
    const YAML::Node n = Section(r, root, "telemetry");
    const std::string p = "telemetry";
    r.Keys(n, p, {"enabled", "lcm_url", "channel_prefix", "joint_state_every",
                  "joint_torque_every", "base_state_every", "contact_every", "friction_every", "disturbance_every", "timing_every",
                  "health_every", "snapshot_queue_capacity", "event_queue_capacity",
                  "command_queue_capacity", "idle_wait_ms"});
    auto& s = c.telemetry;
    s.enabled = BoolOr(r, n, p, "enabled", s.enabled);
    s.lcm_url = StringOr(r, n, p, "lcm_url", s.lcm_url);
    try {
      (void)servo::ParseLcmUrl(s.lcm_url, "telemetry.lcm_url");
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      const std::size_t at = what.find(": expected ");
      r.Fail(n["lcm_url"], what.substr(0, at), what.substr(at + 11, what.rfind(", found ") - at - 11),
             "'" + s.lcm_url + "'");
    }
    s.channel_prefix = StringOr(r, n, p, "channel_prefix", s.channel_prefix);
    if (!servo::IsPlainChannelName(s.channel_prefix + "X"))
      r.Fail(n["channel_prefix"], "telemetry.channel_prefix", "[A-Za-z0-9_]* (no regular expression)",
             "'" + s.channel_prefix + "'");
    // every N cycles (0 = never)
    const auto every = [&](const char* key, std::uint32_t d) {
      return static_cast<std::uint32_t>(BoundedInt(r, n, p, key, static_cast<int>(d), 0, 100000));
    };
    s.joint_state_every = every("joint_state_every", s.joint_state_every);
    s.joint_torque_every = every("joint_torque_every", s.joint_torque_every);
    s.base_state_every = every("base_state_every", s.base_state_every);
    s.contact_every = every("contact_every", s.contact_every);
    s.friction_every = every("friction_every", s.friction_every);
    s.disturbance_every = every("disturbance_every", s.disturbance_every);
    s.timing_every = every("timing_every", s.timing_every);
    s.health_every = every("health_every", s.health_every);
    // queue capacities: powers of two
    const auto capacity = [&](const char* key, std::size_t d) {
      const int v = BoundedInt(r, n, p, key, static_cast<int>(d), 2, 1 << 20);
      if ((v & (v - 1)) != 0)
        r.Fail(n[key], Path(p, key), "a power of two in [2, 1048576]", Describe(n[key]));
      return static_cast<std::size_t>(v);
    };
    s.snapshot_queue_capacity = capacity("snapshot_queue_capacity", s.snapshot_queue_capacity);
    s.event_queue_capacity = capacity("event_queue_capacity", s.event_queue_capacity);
    s.command_queue_capacity = capacity("command_queue_capacity", s.command_queue_capacity);
    s.idle_wait_ms = BoundedInt(r, n, p, "idle_wait_ms", s.idle_wait_ms, 0, 1000);
  }
  {
    const YAML::Node n = Section(r, root, "commands");
    const std::string p = "commands";
    r.Keys(n, p, {"enabled", "channel", "key_file", "max_age_ms", "max_senders", "interface",
                  "max_rate_hz", "mu_min", "mu_max", "gain_scale_min", "gain_scale_max",
                  "max_velocity", "allowed_controllers"});
    auto& s = c.commands;
    s.enabled = BoolOr(r, n, p, "enabled", s.enabled);
    s.channel = StringOr(r, n, p, "channel", s.channel);
    if (!servo::IsPlainChannelName(s.channel))
      r.Fail(n["channel"], "commands.channel",
             "a plain channel name [A-Za-z0-9_]+ (LCM reads a pattern as a regular expression)",
             "'" + s.channel + "'");
    if (s.channel.rfind(c.telemetry.channel_prefix, 0) == 0)
      for (const char* suffix : {"JOINT_STATE", "JOINT_TORQUE", "BASE_STATE", "CONTACT", "TIMING",
                                 "HEALTH", "EVENT"})
        if (s.channel == c.telemetry.channel_prefix + suffix)
          r.Fail(n["channel"], "commands.channel", "a channel the telemetry does not publish on",
                 "'" + s.channel + "'");
    if (n["key_file"].IsDefined()) s.key_file = Resolve(base_dir, StringOr(r, n, p, "key_file", s.key_file));
    s.max_age_ms = Bounded(r, n, p, "max_age_ms", s.max_age_ms, 1.0, 60000.0);
    s.max_senders = static_cast<std::size_t>(
        BoundedInt(r, n, p, "max_senders", static_cast<int>(s.max_senders), 1, 1024));
    s.interface = StringOr(r, n, p, "interface", s.interface);
    s.max_rate_hz = Bounded(r, n, p, "max_rate_hz", s.max_rate_hz, 0.1, 1000.0);
    s.mu_min = Bounded(r, n, p, "mu_min", s.mu_min, 0.0, 10.0);
    s.mu_max = Bounded(r, n, p, "mu_max", s.mu_max, 0.0, 10.0);
    if (s.mu_max < s.mu_min)
      r.Fail(n["mu_max"], Path(p, "mu_max"), "mu_max >= mu_min (" + detail::FormatNumber(s.mu_min) + ")",
             Describe(n["mu_max"]));
    s.gain_scale_min = Bounded(r, n, p, "gain_scale_min", s.gain_scale_min, 1e-3, 100.0);
    s.gain_scale_max = Bounded(r, n, p, "gain_scale_max", s.gain_scale_max, 1e-3, 100.0);
    if (s.gain_scale_max < s.gain_scale_min)
      r.Fail(n["gain_scale_max"], Path(p, "gain_scale_max"),
             "gain_scale_max >= gain_scale_min (" + detail::FormatNumber(s.gain_scale_min) + ")",
             Describe(n["gain_scale_max"]));
    s.max_velocity = VelocityAxes(r, n, p, "max_velocity", s.max_velocity, {1.0, 0.5, 1.5},
                                  "m/s, m/s, rad/s");
    if (n["allowed_controllers"].IsDefined()) {
      const YAML::Node list = n["allowed_controllers"];
      const std::string lp = Path(p, "allowed_controllers");
      if (!list.IsSequence())
        r.Fail(list, lp, "a list of controller names (pid, noslip, stage1, two_stage)", Describe(list));
      s.allowed_controllers.clear();
      for (std::size_t i = 0; i < list.size(); ++i) {
        const std::string ep = lp + "[" + std::to_string(i) + "]";
        const std::string name = list[i].IsScalar() ? list[i].as<std::string>() : std::string();
        if (!servo::ParseControllerKind(name))
          r.Fail(list[i], ep, "one of pid, noslip, stage1, two_stage", Describe(list[i]));
        s.allowed_controllers.push_back(name);
      }
    }
  }
}

// contact.friction_estimation (servo/estimation/friction_estimator.h)
void ReadFrictionEstimation(const Reader& r, const YAML::Node& contact, servo::ServoConfig& c) {
  if (!contact["friction_estimation"].IsDefined()) return;
  const YAML::Node n = r.Map(contact, "contact", "friction_estimation");
  const std::string p = "contact.friction_estimation";
  r.Keys(n, p, {"enabled", "prior_mu", "min_mu", "margin", "min_normal_N", "slip_speed_m_s",
                "slip_cycles", "slip_alignment", "touchdown_blank_s", "stick_speed_m_s",
                "rise_per_s", "slip_filter",
                "confidence_time_s", "memory_radius_m"});
  auto& s = c.friction;
  s.enabled = BoolOr(r, n, p, "enabled", s.enabled);
  s.prior_mu = Bounded(r, n, p, "prior_mu", s.prior_mu, 0.0, 2.0);
  s.min_mu = Bounded(r, n, p, "min_mu", s.min_mu, 0.0, 2.0);
  s.margin = Bounded(r, n, p, "margin", s.margin, 0.0, 0.9);
  s.min_normal_N = Bounded(r, n, p, "min_normal_N", s.min_normal_N, 1.0, 5000.0);
  s.slip_speed_m_s = Bounded(r, n, p, "slip_speed_m_s", s.slip_speed_m_s, 1e-4, 10.0);
  s.slip_cycles = BoundedInt(r, n, p, "slip_cycles", s.slip_cycles, 1, 1000);
  s.slip_alignment = Bounded(r, n, p, "slip_alignment", s.slip_alignment, -1.0, 1.0);
  s.touchdown_blank_s = Bounded(r, n, p, "touchdown_blank_s", s.touchdown_blank_s, 0.0, 1.0);
  s.stick_speed_m_s = Bounded(r, n, p, "stick_speed_m_s", s.stick_speed_m_s, 0.0, 10.0);
  s.rise_per_s = Bounded(r, n, p, "rise_per_s", s.rise_per_s, 0.0, 100.0);
  s.slip_filter = Bounded(r, n, p, "slip_filter", s.slip_filter, 0.0, 1.0);
  s.confidence_time_s = Bounded(r, n, p, "confidence_time_s", s.confidence_time_s, 1e-3, 1e4);
  s.memory_radius_m = Bounded(r, n, p, "memory_radius_m", s.memory_radius_m, 0.0, 10.0);
  if (s.stick_speed_m_s > s.slip_speed_m_s)
    r.Fail(n["stick_speed_m_s"], p + ".stick_speed_m_s",
           "at most slip_speed_m_s (" + std::to_string(s.slip_speed_m_s) + ")",
           std::to_string(s.stick_speed_m_s));
  if (s.min_mu > s.prior_mu)
    r.Fail(n["min_mu"], p + ".min_mu", "at most prior_mu (" + std::to_string(s.prior_mu) + ")",
           std::to_string(s.min_mu));
}

servo::ServoConfig Read(const Reader& r, const YAML::Node& root,
                        const std::filesystem::path& base_dir) {
  if (!root.IsMap()) r.Fail(root, "(top level)", "a map", Describe(root));
  r.Keys(root, "", {"robot", "loop", "buses", "controller", "contact", "reference", "operation",
                    "realtime", "deadline", "safety", "estimator", "telemetry", "commands"});
  servo::ServoConfig c;
  c.source = r.source();

  const YAML::Node robot = r.Map(root, "", "robot");
  r.Keys(robot, "robot", {"urdf", "hal"});
  c.urdf = Resolve(base_dir, r.String(robot, "robot", "urdf"));
  c.hal_file = Resolve(base_dir, r.String(robot, "robot", "hal"));

  const YAML::Node loop = Section(r, root, "loop");
  r.Keys(loop, "loop", {"rate_hz", "clock", "duration_s", "lockstep_timeout_s",
                        "lockstep_short_timeout_s", "lockstep_bringup_timeout_s", "answer_wait_periods"});
  c.lockstep_timeout_s = Bounded(r, loop, "loop", "lockstep_timeout_s", c.lockstep_timeout_s, 1e-3, 60.0);
  c.lockstep_short_timeout_s = Bounded(r, loop, "loop", "lockstep_short_timeout_s",
                                       c.lockstep_short_timeout_s, 1e-4, 60.0);
  c.lockstep_bringup_timeout_s = Bounded(r, loop, "loop", "lockstep_bringup_timeout_s",
                                         c.lockstep_bringup_timeout_s, 0.1, 3600.0);
  c.rate_hz = Bounded(r, loop, "loop", "rate_hz", c.rate_hz, 50.0, 10000.0);
  // in periods, so that a new rate keeps it valid (a fraction of the period); 0.3 by default
  c.answer_wait_s = Bounded(r, loop, "loop", "answer_wait_periods", 0.3, 0.0, 0.5) / c.rate_hz;
  if (loop["clock"].IsDefined())
    c.clock = r.OneOf(loop, "loop", "clock", {"realtime", "lockstep"}) == "lockstep"
                  ? servo::ClockMode::kLockstep
                  : servo::ClockMode::kRealtime;
  c.duration_s = Bounded(r, loop, "loop", "duration_s", c.duration_s, 0.0, 1e7);

  ReadController(r, root, c);

  const YAML::Node contact = Section(r, root, "contact");
  r.Keys(contact, "contact", {"mu", "friction_estimation"});
  if (contact["mu"].IsDefined()) c.mu = PerFoot(r, contact, "contact", "mu", 0.0, 2.0);
  ReadFrictionEstimation(r, contact, c);

  ReadReference(r, root, c);

  const YAML::Node op = Section(r, root, "operation");
  r.Keys(op, "operation", {"auto_enable", "stand_up_s", "sit_down_s", "crouch_height_m",
                           "sit_damping_Nms_per_rad", "sit_settle_speed_rad_s", "sit_damping_max_s"});
  c.auto_enable = BoolOr(r, op, "operation", "auto_enable", c.auto_enable);
  c.stand_up_s = Bounded(r, op, "operation", "stand_up_s", c.stand_up_s, 0.0, 30.0);
  c.sit_down_s = Bounded(r, op, "operation", "sit_down_s", c.sit_down_s, 0.0, 30.0);
  c.crouch_height_m = Bounded(r, op, "operation", "crouch_height_m", c.crouch_height_m, 0.34, 0.6);
  c.sit_damping_Nms_per_rad = Bounded(r, op, "operation", "sit_damping_Nms_per_rad",
                                      c.sit_damping_Nms_per_rad, 0.0, kMaxKdTau);
  c.sit_settle_speed_rad_s = Bounded(r, op, "operation", "sit_settle_speed_rad_s",
                                     c.sit_settle_speed_rad_s, 0.001, 1.0);
  c.sit_damping_max_s = Bounded(r, op, "operation", "sit_damping_max_s", c.sit_damping_max_s, 0.0, 60.0);

  ReadRest(r, root, base_dir, c);

  // the HAL file, then the interface overrides of this file
  c.hal = LoadHalConfig(c.hal_file);
  if (root["buses"].IsDefined()) {
    const YAML::Node b = r.Map(root, "", "buses");
    for (const auto& kv : b) {
      const std::string name = kv.first.as<std::string>();
      bool found = false;
      for (auto& bus : c.hal.buses)
        if (bus.name == name) {
          bus.interface = r.String(b, "buses", name.c_str());
          found = true;
        }
      if (!found) {
        std::string names;
        for (const auto& bus : c.hal.buses) names += (names.empty() ? "" : ", ") + bus.name;
        r.Fail(kv.first, "buses." + name, "a bus of " + c.hal_file + " (" + names + ")",
               "'" + name + "'");
      }
    }
  }
  c.hal.timing.cycle_period_s = 1.0 / c.rate_hz;
  return c;
}

}  // namespace

void ValidateServoConfig(const servo::ServoConfig& c) {
  const double dt = c.period_s();
  auto fail = [&](const std::string& key, const std::string& expected, const std::string& found) {
    throw ConfigError(c.source + ": key '" + key + "': expected " + expected + ", found " + found);
  };
  if (std::abs(c.hal.timing.cycle_period_s - dt) > 1e-12)
    fail("loop.rate_hz", "the HAL's cycle period 1/rate_hz",
         detail::FormatNumber(c.hal.timing.cycle_period_s) + " s");
  if (c.controller.feedback.kd_acc.maxCoeff() * dt > 0.5)
    fail("controller.gains.kd_acc", "kd_acc · dt <= 0.5 at " + detail::FormatNumber(c.rate_hz) + " Hz",
         detail::FormatNumber(c.controller.feedback.kd_acc.maxCoeff()));
  if (c.controller.feedback.kp_acc.maxCoeff() * dt * dt > 0.25)
    fail("controller.gains.kp_acc", "kp_acc · dt² <= 0.25 at " + detail::FormatNumber(c.rate_hz) + " Hz",
         detail::FormatNumber(c.controller.feedback.kp_acc.maxCoeff()));
  const bool pd = c.controller.kind == servo::ControllerKind::kPid
                      ? c.controller.pid.kp.maxCoeff() > 0.0
                  : c.controller.kind == servo::ControllerKind::kPdGravity
                      ? c.controller.pd_gravity.kp.maxCoeff() > 0.0
                      : (c.controller.feedback.kp_tau.maxCoeff() > 0.0 ||
                         c.controller.feedback.kp_acc.maxCoeff() > 0.0);
  if (!pd)
    fail("controller.gains", "a position gain > 0 for the chosen controller (" +
                                 std::string(servo::ToString(c.controller.kind)) + ")",
         "all position gains 0 (the robot would not hold a posture)");
  try {
    hal::ValidateHalConfig(c.hal);  // the bus load at this rate
  } catch (const ConfigError& e) {
    throw ConfigError(c.source + ": key 'loop.rate_hz' = " + detail::FormatNumber(c.rate_hz) +
                      " Hz with " + c.hal_file + ": " + e.what());
  }
}

servo::ServoConfig ParseServoConfig(std::string_view yaml_text, std::string_view source_name,
                                    const std::filesystem::path& base_dir) {
  const Reader r{std::string(source_name)};
  const YAML::Node root = detail::ParseYaml(r, std::string(yaml_text));
  servo::ServoConfig c;
  try {
    c = Read(r, root, base_dir);
  } catch (const YAML::Exception& e) {
    throw ConfigError(r.source() + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  ValidateServoConfig(c);
  return c;
}

servo::ServoConfig LoadServoConfig(const std::filesystem::path& path) {
  return ParseServoConfig(detail::ReadTextFile(path, "the servo configuration"), path.string(),
                          path.parent_path());
}

}  // namespace hyq::config
