#include "tools/loop_model/loop_model.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <stdexcept>
#include <string>
#include <tuple>

#include <Eigen/Geometry>

#include "sim/hydraulic_actuator.h"
#include "sim/plant_profile.h"
#include "tools/loop_model/rational_fit.h"

namespace hyq::loop_model {
namespace {

using dynamics::kJointsPerLeg;
using dynamics::kNumFeet;
using dynamics::kNumJoints;

// the trot's diagonal pairs: lf + rh, rf + lh
constexpr std::array<int, kNumFeet> kPartner{3, 2, 1, 0};

dynamics::VectorQ FullPosture(const servo::ReferenceSample& s) {
  dynamics::VectorQ q;
  q.head<3>() = s.base.p_W;
  const Eigen::Quaterniond r(Eigen::AngleAxisd(s.base.yaw, Eigen::Vector3d::UnitZ()));
  q.segment<4>(3) << r.w(), r.x(), r.y(), r.z();
  q.tail<kNumJoints>() = s.joints.q;
  return q;
}

void Widen(int joint, double value, PhaseInertia* p) {
  p->min(joint) = std::min(p->min(joint), value);
  p->max(joint) = std::max(p->max(joint), value);
}

LoopRow EvaluateRow(const LoopModel& m, const JointGains& g, int joint, Phase phase,
                    PlantKind plant) {
  const LoopModelSettings& s = m.settings;
  const PhaseInertia& in = m.inertia[static_cast<std::size_t>(phase)];
  const ActuatorModel& a =
      m.actuators[static_cast<std::size_t>(plant)][static_cast<std::size_t>(phase)][static_cast<std::size_t>(joint)];
  LoopRow r;
  r.joint = joint;
  r.phase = phase;
  r.plant = plant;
  r.inertia_kgm2 = in.nominal(joint);
  r.inertia_min = in.min(joint);
  r.inertia_max = in.max(joint);
  const JointLoop loop = MakeJointLoop(s, g, a, joint, phase, r.inertia_kgm2);
  r.kp = loop.kp;
  r.kd = loop.kd;
  r.ki = loop.ki;
  r.plant_delay_cycles = a.own_delay_cycles;
  r.margins = ComputeMargins(loop);
  r.max_extra_cycles = MaxStableExtraCycles(loop, s.max_extra_cycles);
  r.max_extra_cycles_over_range = r.max_extra_cycles;
  for (double I : {r.inertia_min, r.inertia_max}) {
    if (I == r.inertia_kgm2) continue;
    const int k = MaxStableExtraCycles(MakeJointLoop(s, g, a, joint, phase, I), s.max_extra_cycles);
    r.max_extra_cycles_over_range = std::min(r.max_extra_cycles_over_range, k);
  }
  r.stable_at_report = ClosedLoopStable(loop, s.report_extra_cycles);
  // unstable: the root that grows fastest; stable: the least damped oscillation
  r.root_at_report = DominantRoot(loop, s.report_extra_cycles, r.stable_at_report);
  return r;
}

}  // namespace

const char* ToString(Phase p) noexcept {
  switch (p) {
    case Phase::kSwing: return "swing";
    case Phase::kTrotStance: return "stance";
    case Phase::kStand: return "stand";
  }
  return "?";
}

const char* ToString(PlantKind p) noexcept {
  return p == PlantKind::kIdeal ? "ideal" : "realistic";
}

JointGains GainsOf(const servo::ControllerConfig& c, servo::ControllerKind kind) {
  JointGains g;
  switch (kind) {
    case servo::ControllerKind::kPid:
      g.kp = c.pid.kp;
      g.kd = c.pid.kd;
      g.ki = c.pid.ki;
      g.swing_scale = c.pid_swing_gain_scale;
      break;
    case servo::ControllerKind::kPdGravity:
      g.kp = c.pd_gravity.kp;
      g.kd = c.pd_gravity.kd;
      g.swing_scale = c.pdg_swing_gain_scale;
      break;
    case servo::ControllerKind::kNoSlipId:
    case servo::ControllerKind::kStage1Id:
    case servo::ControllerKind::kTwoStageId:
      g.kp = c.feedback.kp_tau;
      g.kd = c.feedback.kd_tau;
      g.ki = c.feedback.ki_tau;
      g.swing_scale = c.swing_gain_scale;
      break;
  }
  return g;
}

StanceSet StanceOf(Phase phase, int joint) {
  const int leg = joint / kJointsPerLeg;
  StanceSet s{false, false, false, false};
  switch (phase) {
    case Phase::kSwing: break;
    case Phase::kTrotStance:
      s[static_cast<std::size_t>(leg)] = true;
      s[static_cast<std::size_t>(kPartner[static_cast<std::size_t>(leg)])] = true;
      break;
    case Phase::kStand: s.fill(true); break;
  }
  return s;
}

std::array<PhaseInertia, kNumPhases> ComputeInertias(const dynamics::Model& model,
                                                     const servo::TrotParams& trot) {
  std::array<PhaseInertia, kNumPhases> out;
  const dynamics::VectorQ q0 = model.StandingQ();
  auto& swing = out[static_cast<std::size_t>(Phase::kSwing)];
  auto& stance = out[static_cast<std::size_t>(Phase::kTrotStance)];
  auto& stand = out[static_cast<std::size_t>(Phase::kStand)];
  swing.nominal = SwingInertia(model, q0);
  swing.free_leg = FreeLegInertia(model, q0);
  const dynamics::VectorJ lfrh = StanceInertia(model, q0, StanceOf(Phase::kTrotStance, 0));
  const dynamics::VectorJ rflh = StanceInertia(model, q0, StanceOf(Phase::kTrotStance, 3));
  for (int j = 0; j < kNumJoints; ++j) {
    const int leg = j / kJointsPerLeg;
    stance.nominal(j) = (leg == 0 || leg == 3) ? lfrh(j) : rflh(j);
  }
  stand.nominal = StanceInertia(model, q0, StanceOf(Phase::kStand, 0));
  for (PhaseInertia* p : {&swing, &stance, &stand}) {
    p->min = p->nominal;
    p->max = p->nominal;
  }
  // above the other joints' crossovers they no longer hold still: the leg's free inertia (3)
  // bounds the swing's from below
  swing.min = swing.min.cwiseMin(swing.free_leg);
  // one gait cycle of the steady trot, every 2 ms
  servo::Reference ref = servo::Reference::Trot(model, trot);
  const double cycle = 1.0 / trot.step_frequency_Hz;
  const double t0 = trot.start_delay_s + trot.ramp_s + cycle;
  servo::ReferenceSample s;
  for (double t = 0.0; t < t0 + cycle; t += 2e-3) {
    ref.Sample(t, &s);
    if (t < t0 || s.ik != dynamics::IkStatus::kOk) continue;
    const dynamics::VectorQ q = FullPosture(s);
    const auto& st = s.joints.stance;
    int on_ground = 0;
    for (bool b : st) on_ground += b ? 1 : 0;
    if (on_ground < kNumFeet) {
      const dynamics::VectorJ Is = SwingInertia(model, q), If = FreeLegInertia(model, q);
      for (int j = 0; j < kNumJoints; ++j)
        if (!st[static_cast<std::size_t>(j / kJointsPerLeg)]) {
          Widen(j, Is(j), &swing);
          Widen(j, If(j), &swing);
        }
    }
    if (on_ground == 2) {
      const dynamics::VectorJ Ic = StanceInertia(model, q, st);
      for (int j = 0; j < kNumJoints; ++j)
        if (st[static_cast<std::size_t>(j / kJointsPerLeg)]) Widen(j, Ic(j), &stance);
    }
  }
  return out;
}

ActuatorModel LagActuator(double tau_s, double period_s) {
  ActuatorModel a;
  if (tau_s > 0) {
    // SimulatedRobot's eq. (1): τ[n] = τ[n−1] + α (u[n] − τ[n−1]), applied over step n
    const double alpha = -std::expm1(-period_s / tau_s);
    a.setpoint = TransferFunction({0.0, alpha}, {-(1.0 - alpha), 1.0});
  }
  a.motion = TransferFunction::Gain(0.0);
  return a;
}

ActuatorModel HydraulicActuatorModel(const dynamics::Model& model, const hal::JointCalibration& cal,
                                     int joint, double q_joint, double tau_bias_Nm,
                                     const LoopModelSettings& s) {
  const sim::PlantProfile profile = sim::PlantProfile::Realistic();
  const auto& lim = model.limits[static_cast<std::size_t>(joint)];
  const std::string& name = model.joint_names[static_cast<std::size_t>(joint)];
  ActuatorModel a;
  a.own_delay_cycles = profile.delay_cycles;
  a.viscous_Nms = profile.joint_friction.enabled
                      ? profile.joint_friction.viscous_Nm_s[static_cast<std::size_t>(joint % kJointsPerLeg)]
                      : 0.0;
  a.operating_torque_Nm = tau_bias_Nm;
  const double T = s.period_s;
  for (const SineWindow& w : LogSpacedWindows(s.measure_f_lo_hz, s.measure_f_hi_hz, s.measure_points, T)) {
    const int settle = std::max(100, w.samples / 3);
    // A: the set-point's sine, the joint clamped at q
    {
      sim::HydraulicActuator act(profile.hydraulic, cal, lim.lower_rad, lim.upper_rad, T, name);
      act.Reset(q_joint, tau_bias_Nm);
      const SampleStep step = [&](long, double, double x) { return act.Step(tau_bias_Nm + x, q_joint, 0.0); };
      a.setpoint_measured.push_back({w.f_hz, MeasureResponse(step, w, s.setpoint_amplitude_Nm, settle)});
    }
    // Z: the joint moving about q at q̇ = a sin(θn), the set-point held; Z = −τ / q̇
    {
      sim::HydraulicActuator act(profile.hydraulic, cal, lim.lower_rad, lim.upper_rad, T, name);
      act.Reset(q_joint, tau_bias_Nm);
      const double amp = s.motion_amplitude_rad_s;
      const SampleStep step = [&](long n, double theta, double v) {
        const double q = q_joint - amp * T / theta * std::cos(theta * static_cast<double>(n));
        return -act.Step(tau_bias_Nm, q, v);
      };
      a.motion_measured.push_back({w.f_hz, MeasureResponse(step, w, amp, settle)});
    }
  }
  const RationalFit fa = FitBestOrder(a.setpoint_measured, T, s.fit_order);
  const RationalFit fz = FitBestOrder(a.motion_measured, T, s.fit_order);
  a.setpoint = fa.model;
  a.motion = fz.model;
  a.setpoint_fit_error = fa.band_relative_error;
  a.motion_fit_error = fz.band_relative_error;
  return a;
}

JointLoop MakeJointLoop(const LoopModelSettings& s, const JointGains& g, const ActuatorModel& a,
                        int joint, Phase phase, double inertia_kgm2) {
  const double scale = phase == Phase::kSwing ? g.swing_scale : 1.0;
  JointLoop loop;
  loop.period_s = s.period_s;
  loop.inertia_kgm2 = inertia_kgm2;
  loop.kp = scale * g.kp(joint);
  loop.kd = scale * g.kd(joint);
  loop.ki = g.ki(joint);
  loop.velocity_alpha =
      s.velocity_cutoff_hz > 0 ? -std::expm1(-2.0 * std::numbers::pi * s.velocity_cutoff_hz * s.period_s) : 1.0;
  loop.delay_cycles = 1 + a.own_delay_cycles;
  loop.actuator = a.setpoint;
  loop.motion = a.motion;
  loop.viscous_Nms = a.viscous_Nms;
  loop.mechanics = s.mechanics;
  return loop;
}

LoopModel BuildLoopModel(const dynamics::Model& model,
                         const std::array<hal::JointCalibration, kNumJoints>& joints,
                         const JointGains& gains, const LoopModelSettings& s,
                         const std::vector<PlantKind>& plants) {
  LoopModel m;
  m.settings = s;
  m.gains = gains;
  m.inertia = ComputeInertias(model, s.trot);
  const dynamics::VectorQ q0 = model.StandingQ();
  for (PlantKind plant : plants) {
    for (int p = 0; p < kNumPhases; ++p) {
      const Phase phase = static_cast<Phase>(p);
      // the torques holding the standing posture on the phase's feet (per leg's own stance set)
      std::array<dynamics::VectorJ, kNumFeet> hold;
      for (int leg = 0; leg < kNumFeet; ++leg)
        hold[static_cast<std::size_t>(leg)] = HoldingTorque(model, q0, StanceOf(phase, kJointsPerLeg * leg));
      for (int j = 0; j < kNumJoints; ++j) {
        auto& slot = m.actuators[static_cast<std::size_t>(plant)][static_cast<std::size_t>(p)][static_cast<std::size_t>(j)];
        slot = plant == PlantKind::kIdeal
                   ? LagActuator(s.actuator_tau_s, s.period_s)
                   : HydraulicActuatorModel(model, joints[static_cast<std::size_t>(j)], j,
                                            model.q_standing(j),
                                            hold[static_cast<std::size_t>(j / kJointsPerLeg)](j), s);
      }
    }
  }
  for (int j = 0; j < kNumJoints; ++j)
    for (int p = 0; p < kNumPhases; ++p)
      for (PlantKind plant : plants) m.rows.push_back(EvaluateRow(m, gains, j, static_cast<Phase>(p), plant));
  return m;
}

std::vector<LoopRow> Evaluate(const LoopModel& m, const JointGains& g) {
  std::vector<LoopRow> rows;
  rows.reserve(m.rows.size());
  for (const LoopRow& r : m.rows) rows.push_back(EvaluateRow(m, g, r.joint, r.phase, r.plant));
  return rows;
}

std::vector<LoopRow> WorstPerJointType(const std::vector<LoopRow>& rows) {
  std::map<std::tuple<int, int, int>, LoopRow> worst;
  for (const LoopRow& r : rows) {
    const auto key = std::make_tuple(r.joint % kJointsPerLeg, static_cast<int>(r.phase), static_cast<int>(r.plant));
    auto it = worst.find(key);
    const bool less =
        it == worst.end() || r.max_extra_cycles < it->second.max_extra_cycles ||
        (r.max_extra_cycles == it->second.max_extra_cycles &&
         r.margins.delay_margin_s < it->second.margins.delay_margin_s);
    if (less) worst[key] = r;
  }
  std::vector<LoopRow> out;
  for (const auto& [key, r] : worst) out.push_back(r);
  return out;
}

}  // namespace hyq::loop_model
