// The loop model behind hyq-loop-model (tools/loop_model/): the inertias against MuJoCo's
// (mj_fullM, mj_jac: another implementation of the same model), a loop whose margins are known
// in closed form, its elements against the plant's own classes driven the same way, a one-joint
// simulation of those classes against the predicted closed-loop root, and the measured fact it
// must predict: the swing knee on the ideal plant with 2 extra cycles of delay (label tools).
#include <cmath>
#include <complex>
#include <cstdio>
#include <deque>
#include <numbers>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "config/servo_config_loader.h"
#include "sim/board_velocity.h"
#include "sim/plant.h"
#include "sim/plant_profile.h"
#include "tests/dynamics/hyq_fixture.h"
#include "tests/support/paths.h"
#include "tools/loop_model/frequency_response.h"
#include "tools/loop_model/gain_search.h"
#include "tools/loop_model/joint_inertia.h"
#include "tools/loop_model/joint_loop.h"
#include "tools/loop_model/loop_model.h"
#include "tools/loop_model/rational_fit.h"
#include "tools/loop_model/transfer_function.h"

namespace hyq::loop_model {
namespace {

using dynamics::kNumJoints;
using dynamics::kNv;
using testing::HyqModel;
constexpr double kPi = std::numbers::pi;
constexpr double kT = 1e-3;

const servo::ServoConfig& SimConfig() {
  static const servo::ServoConfig c =
      config::LoadServoConfig(testing::SourceDir() / "config/hyq_servo_sim.yaml");
  return c;
}

// the shipped configuration's model on both plants, built once (the hydraulics' measurement)
const LoopModel& ShippedModel() {
  static const LoopModel m = [] {
    LoopModelSettings s;
    s.trot = SimConfig().trot;
    return BuildLoopModel(HyqModel(), SimConfig().hal.joints,
                          GainsOf(SimConfig().controller, SimConfig().controller.kind), s,
                          {PlantKind::kIdeal, PlantKind::kRealistic});
  }();
  return m;
}

// the gains the measured fact below was measured with (the two-stage ID's kp 837.9 N m/rad,
// kd 28.2 N m s/rad, swing scale 0.3, shipped until the delay-aware tuning)
servo::ControllerConfig MeasuredController() {
  servo::ControllerConfig c = SimConfig().controller;
  c.kind = servo::ControllerKind::kTwoStageId;
  c.feedback.kp_tau.setConstant(837.9);
  c.feedback.kd_tau.setConstant(28.2);
  c.swing_gain_scale = 0.3;
  return c;
}

const LoopModel& MeasuredModel() {
  static const LoopModel m = [] {
    LoopModelSettings s;
    s.trot = SimConfig().trot;
    return BuildLoopModel(HyqModel(), SimConfig().hal.joints,
                          GainsOf(MeasuredController(), servo::ControllerKind::kTwoStageId), s,
                          {PlantKind::kIdeal, PlantKind::kRealistic});
  }();
  return m;
}

dynamics::VectorQ TiltedPosture() {
  dynamics::VectorQ q = HyqModel().StandingQ();
  const Eigen::Quaterniond r(Eigen::AngleAxisd(0.2, Eigen::Vector3d(1, 2, 3).normalized()));
  q.segment<4>(3) << r.w(), r.x(), r.y(), r.z();
  q.tail<kNumJoints>() += 0.15 * dynamics::VectorJ::LinSpaced(-1.0, 1.0);
  return q;
}

// --- the inertias against MuJoCo -----------------------------------------------------------------

struct MujocoDynamics {
  Eigen::MatrixXd M;                          // mj_fullM
  std::array<Eigen::MatrixXd, 4> J_foot;      // mj_jac at each foot sphere's centre, 3 x nv
};

MujocoDynamics FromMujoco(const dynamics::VectorQ& q) {
  sim::Plant plant(HyqModel(), sim::PlantConfig{});
  plant.Reset(q, dynamics::VectorV::Zero());
  const mjModel* m = plant.mj_model();
  mjData* d = plant.mj_data();
  MujocoDynamics out;
  Eigen::Matrix<mjtNum, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> M(m->nv, m->nv);
  mj_fullM(m, M.data(), d->qM);
  out.M = M;
  for (int f = 0; f < 4; ++f) {
    const int g = mj_name2id(m, mjOBJ_GEOM, HyqModel().feet[static_cast<std::size_t>(f)].name.c_str());
    EXPECT_GE(g, 0);
    Eigen::Matrix<mjtNum, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> jp(3, m->nv);
    mj_jac(m, d, jp.data(), nullptr, d->geom_xpos + 3 * g, m->geom_bodyid[g]);
    out.J_foot[static_cast<std::size_t>(f)] = jp;
  }
  return out;
}

TEST(LoopModelInertia, SwingIsMujocosLegDiagonal) {
  for (const dynamics::VectorQ& q : {HyqModel().StandingQ(), TiltedPosture()}) {
    const MujocoDynamics mj = FromMujoco(q);
    const dynamics::VectorJ swing = SwingInertia(HyqModel(), q);
    const dynamics::VectorJ free = FreeLegInertia(HyqModel(), q);
    for (int j = 0; j < kNumJoints; ++j) {
      const int v = dynamics::VIndexOfJoint(j);
      EXPECT_NEAR(swing(j), mj.M(v, v), 1e-6 * mj.M(v, v)) << HyqModel().joint_names[static_cast<std::size_t>(j)];
      // (3): the leg's block inverted
      const int v0 = v - j % 3;
      const Eigen::Matrix3d inv = mj.M.block<3, 3>(v0, v0).inverse();
      EXPECT_NEAR(free(j), 1.0 / inv(j % 3, j % 3), 1e-6 * free(j));
      EXPECT_LE(free(j), swing(j) * (1 + 1e-12));
    }
  }
}

// (2) by another route: the motions the contacts allow, v = N y with N a basis of null(J); the
// reduced inertia Nᵀ M N; a torque e_j gives q̈ = N (Nᵀ M N)⁻¹ Nᵀ e_j; I_j = 1 / q̈_j. M and J
// are MuJoCo's.
double NullSpaceInertia(const MujocoDynamics& mj, const StanceSet& stance, int joint) {
  std::vector<Eigen::MatrixXd> rows;
  for (int f = 0; f < 4; ++f)
    if (stance[static_cast<std::size_t>(f)]) rows.push_back(mj.J_foot[static_cast<std::size_t>(f)]);
  Eigen::MatrixXd J(3 * static_cast<int>(rows.size()), kNv);
  for (std::size_t i = 0; i < rows.size(); ++i) J.middleRows(3 * static_cast<int>(i), 3) = rows[i];
  Eigen::FullPivLU<Eigen::MatrixXd> lu(J);
  const Eigen::MatrixXd N = lu.kernel();
  const Eigen::MatrixXd Mr = N.transpose() * mj.M * N;
  Eigen::VectorXd e = Eigen::VectorXd::Zero(kNv);
  e(dynamics::VIndexOfJoint(joint)) = 1.0;
  const Eigen::VectorXd qdd = N * Mr.ldlt().solve(N.transpose() * e);
  return 1.0 / qdd(dynamics::VIndexOfJoint(joint));
}

TEST(LoopModelInertia, StanceIsTheConstrainedSystemsAsMujocoHasIt) {
  const std::vector<StanceSet> sets = {{true, false, false, true},
                                       {false, true, true, false},
                                       {true, true, true, true},
                                       {true, true, true, false}};
  for (const dynamics::VectorQ& q : {HyqModel().StandingQ(), TiltedPosture()}) {
    const MujocoDynamics mj = FromMujoco(q);
    for (const StanceSet& st : sets) {
      const dynamics::VectorJ I = StanceInertia(HyqModel(), q, st);
      for (int j = 0; j < kNumJoints; ++j) {
        const double ref = NullSpaceInertia(mj, st, j);
        EXPECT_NEAR(I(j), ref, 1e-6 * ref) << HyqModel().joint_names[static_cast<std::size_t>(j)];
      }
    }
  }
}

TEST(LoopModelInertia, StanceLegsCarryTheBodysInertia) {
  // the diagonal pair: a stance joint sees far more than the leg alone; the torques that hold
  // the posture carry the weight: Σ over the stance feet's vertical forces = m g (checked
  // through the knee torques' sign and size only loosely: a physical sanity check)
  const dynamics::VectorQ q = HyqModel().StandingQ();
  const dynamics::VectorJ swing = SwingInertia(HyqModel(), q);
  const dynamics::VectorJ stance = StanceInertia(HyqModel(), q, StanceOf(Phase::kTrotStance, 0));
  for (int j : {0, 1, 2, 9, 10, 11}) EXPECT_GT(stance(j), 3.0 * swing(j)) << j;
  const dynamics::VectorJ hold4 = HoldingTorque(HyqModel(), q, StanceOf(Phase::kStand, 0));
  const dynamics::VectorJ hold2 = HoldingTorque(HyqModel(), q, StanceOf(Phase::kTrotStance, 0));
  EXPECT_NEAR(hold2(2) / hold4(2), 2.0, 0.3);  // half the feet, about twice the knee torque
}

// --- a loop with margins in closed form --------------------------------------------------------

// A mass I under kd alone (plain difference, no lag, d cycles of delay): with a = kd T / I,
//   q̇[n+1] = q̇[n] − a q̇[n − d],  L(z) = a z^{−d} / (z − 1),
// stable iff 0 < a < 2 cos(dπ / (2d + 1)) [S. A. Levin, R. M. May, "A note on difference-delay
// equations", Theor. Popul. Biol. 9, 1976]; |L(e^{jθ})| = a / (2 sin(θ/2)) gives the crossover
// θ_c = 2 asin(a/2), arg L = −dθ − θ/2 − π/2 the phase margin π/2 − (d + ½) θ_c, the delay
// margin π/(2θ_c) − d − ½ samples, the phase crossover θ_π = π/(2d + 1), the gain margin
// 2 sin(θ_π/2) / a.
JointLoop KdOnly(double a, int d) {
  JointLoop loop;
  loop.period_s = kT;
  loop.inertia_kgm2 = 0.02;
  loop.kd = a * loop.inertia_kgm2 / kT;
  loop.kp = 1e-4;  // a trace of stiffness: the position's own mode, else on the circle, inside
  loop.velocity_alpha = 1.0;
  loop.delay_cycles = d;
  loop.actuator = TransferFunction::Gain(1.0);
  return loop;
}

int LevinMayLargestDelay(double a) {
  int d = 0;
  while (a < 2.0 * std::cos((d + 1) * kPi / (2 * (d + 1) + 1))) ++d;
  return d;
}

TEST(LoopModelLoop, KdOnlyMassHasTheClosedFormMargins) {
  for (double a : {0.2, 0.3, 0.4, 0.55, 0.8, 0.95}) {
    for (int d : {1, 2}) {
      const JointLoop loop = KdOnly(a, d);
      const double theta_c = 2.0 * std::asin(a / 2.0);
      const double pm = kPi / 2.0 - (d + 0.5) * theta_c;
      const double theta_pi = kPi / (2 * d + 1);
      const Margins m = ComputeMargins(loop);
      SCOPED_TRACE("a " + std::to_string(a) + ", d " + std::to_string(d));
      if (pm <= 0.0) {
        EXPECT_FALSE(m.stable);
        EXPECT_EQ(MaxStableExtraCycles(loop, 40), -1);
        continue;
      }
      ASSERT_TRUE(m.stable);
      ASSERT_TRUE(m.has_crossover);
      EXPECT_NEAR(m.crossover_hz, theta_c / (2 * kPi * kT), 1e-6 * m.crossover_hz);
      EXPECT_NEAR(m.phase_margin_deg, pm * 180.0 / kPi, 1e-4);
      EXPECT_NEAR(m.delay_margin_s / kT, kPi / (2 * theta_c) - d - 0.5, 1e-4);
      EXPECT_NEAR(m.gain_margin, 2.0 * std::sin(theta_pi / 2.0) / a, 1e-5 * m.gain_margin);
      // the exact count: Levin and May's bound, and the continuous margin's whole cycles
      const int k = LevinMayLargestDelay(a) - d;
      EXPECT_EQ(MaxStableExtraCycles(loop, 40), k);
      EXPECT_EQ(static_cast<int>(std::floor(m.delay_margin_s / kT)), k);
      // L itself
      const double th = 0.3;
      const std::complex<double> z = std::polar(1.0, th);
      const std::complex<double> expected = a * std::pow(z, -static_cast<double>(d)) / (z - 1.0);
      EXPECT_LT(std::abs(OpenLoopAt(loop, 0, th) - expected), 1e-6 * std::abs(expected));
    }
  }
}

// --- the elements against the plant's classes ---------------------------------------------------

TEST(LoopModelElements, TheLagIsSimulatedRobotsActuation) {
  sim::PlantProfile ideal = sim::PlantProfile::Ideal();
  sim::Actuation act(HyqModel(), {}, ideal, 0.005, 0.0, kT);
  act.Reset(dynamics::VectorJ::Zero());
  const ActuatorModel lag = LagActuator(0.005, kT);
  for (const SineWindow& w : LogSpacedWindows(1.0, 450.0, 12, kT)) {
    act.Reset(dynamics::VectorJ::Zero());
    const SampleStep step = [&](long, double, double x) {
      act.Step(dynamics::VectorJ::Constant(x), dynamics::VectorJ::Zero(), dynamics::VectorJ::Zero());
      return act.applied_Nm()(0);
    };
    const std::complex<double> measured = MeasureResponse(step, w, 1.0, 2000);
    const std::complex<double> model = lag.setpoint.AtAngle(2 * kPi * w.f_hz * kT);
    EXPECT_LT(std::abs(measured - model), 1e-9) << w.f_hz << " Hz";
  }
}

TEST(LoopModelElements, TheVelocityIsTheBoardsFilter) {
  const auto& joints = SimConfig().hal.joints;
  JointLoop loop;
  loop.kd = 1.0;  // C(z) = V(z)
  loop.velocity_alpha = -std::expm1(-2 * kPi * sim::kBoardVelocityCutoffHz * kT);
  const TransferFunction V = Controller(loop);
  for (const SineWindow& w : LogSpacedWindows(2.0, 400.0, 10, kT)) {
    sim::BoardVelocity bv(joints, kT, sim::kBoardVelocityCutoffHz);
    bv.Reset(dynamics::VectorJ::Zero());
    // a sine of 0.5 rad: the encoder's quantisation (47.9 µrad) is 10⁻⁴ of it
    const SampleStep step = [&](long, double, double x) {
      bv.Step(dynamics::VectorJ::Constant(x));
      return bv.velocity_rad_s()(1);
    };
    const std::complex<double> measured = MeasureResponse(step, w, 0.5, 200);
    const std::complex<double> model = V.AtAngle(2 * kPi * w.f_hz * kT);
    EXPECT_LT(std::abs(measured - model), 2e-3 * std::abs(model)) << w.f_hz << " Hz";
  }
}

TEST(LoopModelElements, RationalFitRecoversAKnownSystem) {
  // poles 0.9, 0.6 ± 0.3j; a zero; sampled where the hydraulics are
  const TransferFunction H({0.05, -0.02, 0.3, 0.1},
                           Multiply(Polynomial{-0.9, 1.0}, Polynomial{0.45, -1.2, 1.0}));
  std::vector<ResponsePoint> pts;
  for (const SineWindow& w : LogSpacedWindows(2.0, 480.0, 40, kT))
    pts.push_back({w.f_hz, H.AtAngle(2 * kPi * w.f_hz * kT)});
  const RationalFit fit = FitRational(pts, kT, 3);
  EXPECT_LT(fit.max_relative_error, 1e-8);
  const RationalFit best = FitBestOrder(pts, kT, 6);
  EXPECT_LT(best.max_relative_error, 1e-6);
  EXPECT_EQ(best.model.den().size(), 4u);  // order 3: the lowest that fits
}

TEST(LoopModelElements, HydraulicFitsFollowTheirMeasurements) {
  const LoopModel& m = ShippedModel();
  for (int p = 0; p < kNumPhases; ++p)
    for (int j = 0; j < kNumJoints; ++j) {
      const ActuatorModel& a = m.actuators[1][static_cast<std::size_t>(p)][static_cast<std::size_t>(j)];
      EXPECT_LT(a.setpoint_fit_error, 0.02) << ToString(static_cast<Phase>(p)) << " " << j;
      EXPECT_LT(a.motion_fit_error, 0.10) << ToString(static_cast<Phase>(p)) << " " << j;
      for (const TransferFunction* tf : {&a.setpoint, &a.motion}) {
        const Eigen::VectorXcd poles = tf->Poles();
        for (Eigen::Index i = 0; i < poles.size(); ++i) EXPECT_LT(std::abs(poles(i)), 1.0);
      }
    }
}

// The realistic cylinders push along the joint's motion below ~30 Hz: the boards' velocity
// compensation opens the valve for the piston side's flow A_a L̇, which through the same spool
// over-drains (extending) or over-fills (retracting) the rod side (A_b = 0.61 A_a) at the
// pressures the joint works at (docs/tuning.md, "Loop model"). The rotary HAA does not.
// the boards' velocity compensation cancels the cylinders' natural velocity feedback and no more
// (sim/hydraulic_actuator.h, (6)): every joint's motion costs it torque at 10 Hz (sized for the
// piston side alone it over-fed the rod side, and HFE and KFE pushed along their own motion,
// about −10 N m s/rad)
TEST(LoopModelElements, RealisticActuatorsDoNotPushAlongTheirOwnMotion) {
  const LoopModel& m = ShippedModel();
  const double theta = 2 * kPi * 10.0 * kT;
  for (int leg = 0; leg < 4; ++leg) {
    const auto& sw = m.actuators[1][static_cast<std::size_t>(Phase::kSwing)];
    for (int k = 0; k < 3; ++k)
      EXPECT_GT(sw[static_cast<std::size_t>(3 * leg + k)].motion.AtAngle(theta).real(), 0.0) << leg << " " << k;
  }
}

// --- the model against a simulation of the plant's own classes -----------------------------------

// One joint of inertia I: sim::Actuation (the ideal profile's lag), its transport delay, the
// boards' velocity (sim::BoardVelocity), MuJoCo's semi-implicit Euler step, and the PD of C(z)
// one bus cycle + K late: the oscillation grows or decays as the model's dominant root says.
TEST(LoopModelLoop, OneJointSimulationFollowsTheDominantRoot) {
  const auto& joints = SimConfig().hal.joints;
  const LoopModelSettings s;
  const JointGains g = GainsOf(MeasuredController(), servo::ControllerKind::kTwoStageId);
  for (int extra : {1, 2}) {
    const double I = 0.02618;  // the swing knee
    const JointLoop loop = MakeJointLoop(s, g, LagActuator(0.005, kT), 2, Phase::kSwing, I);
    const ClosedLoopRoot r = DominantRoot(loop, extra, true);
    sim::Actuation act(HyqModel(), {}, sim::PlantProfile::Ideal(), 0.005, 0.0, kT);
    sim::BoardVelocity bv(joints, kT, sim::kBoardVelocityCutoffHz);
    double q = 0.05, v = 0.0;
    act.Reset(dynamics::VectorJ::Zero());
    bv.Reset(dynamics::VectorJ::Constant(q));
    std::deque<double> line(static_cast<std::size_t>(loop.delay_cycles + extra), 0.0);
    std::vector<double> trace;
    for (int n = 0; n < 450; ++n) {
      // the set-point of this step was computed delay cycles ago from the measurement then
      const double u = -loop.kp * q - loop.kd * bv.velocity_rad_s()(2);
      line.push_back(u);
      const double cmd = line.front();
      line.pop_front();
      act.Step(dynamics::VectorJ::Constant(cmd), dynamics::VectorJ::Zero(), dynamics::VectorJ::Zero());
      v += kT * act.applied_Nm()(2) / I;
      q += kT * v;
      bv.Step(dynamics::VectorJ::Constant(q));
      trace.push_back(q);
    }
    // the envelope's rate from 0.1-0.15 s to 0.4-0.45 s (the decaying case stays far above the
    // encoder's count), the zero crossings' frequency between
    auto peak = [&](int a, int b) {
      double m = 0.0;
      for (int i = a; i < b; ++i) m = std::max(m, std::abs(trace[static_cast<std::size_t>(i)]));
      return m;
    };
    const double rate = std::log(peak(400, 450) / peak(100, 150)) / 0.3;
    int crossings = 0;
    for (int i = 101; i < 450; ++i)
      if ((trace[static_cast<std::size_t>(i)] > 0) != (trace[static_cast<std::size_t>(i - 1)] > 0)) ++crossings;
    const double f = crossings / 2.0 / 0.349;
    SCOPED_TRACE("extra " + std::to_string(extra));
    EXPECT_NEAR(rate, std::log(r.magnitude) / kT, 1.5);  // 1/s
    EXPECT_NEAR(f, r.frequency_hz, 1.0);
  }
}

// --- the measured fact -------------------------------------------------------------------------

// scripts/hil.sh --duration 20 --sim-arg --delay-cycles --sim-arg 2 (the ideal plant, the shipped
// gains): the swing knees (rf_kfe, lh_kfe) ring at 35-37 Hz, growing ~19/s, to the 15 rad/s
// fault at 2.77 s (2026-12-04); without the extra delay the trot walks.
TEST(LoopModelPrediction, SwingKneeOnTheIdealPlantLosesStabilityWithTwoExtraCycles) {
  const LoopModel& m = MeasuredModel();
  for (const LoopRow& r : m.rows) {
    if (r.plant != PlantKind::kIdeal || r.phase != Phase::kSwing || r.joint % 3 != 2) continue;
    SCOPED_TRACE(HyqModel().joint_names[static_cast<std::size_t>(r.joint)]);
    EXPECT_EQ(r.max_extra_cycles, 1);              // stable with 0 and 1, not with 2
    EXPECT_EQ(r.max_extra_cycles_over_range, 1);
    EXPECT_FALSE(r.stable_at_report);              // report_extra_cycles = 2
    EXPECT_GT(r.root_at_report.magnitude, 1.0);
    EXPECT_NEAR(r.root_at_report.frequency_hz, 36.0, 3.0);
    EXPECT_NEAR(r.margins.crossover_hz, 35.0, 3.0);
  }
  // and every other ideal loop of those gains keeps more than 2
  for (const LoopRow& r : m.rows) {
    if (r.plant == PlantKind::kIdeal && !(r.phase == Phase::kSwing && r.joint % 3 == 2)) {
      EXPECT_GT(r.max_extra_cycles, 2) << r.joint << " " << ToString(r.phase);
    }
  }
}

// the shipped gains (scripts/tune_gains.py's rule: they walk with 2 extra cycles through the
// loop on both plants): the model gives every loop, every phase, both plants, over the inertias'
// range, at least 2 extra cycles too
TEST(LoopModelPrediction, TheShippedGainsKeepTwoExtraCyclesEverywhere) {
  for (const LoopRow& r : ShippedModel().rows) {
    EXPECT_GE(r.max_extra_cycles_over_range, 2)
        << HyqModel().joint_names[static_cast<std::size_t>(r.joint)] << " " << ToString(r.phase);
    EXPECT_TRUE(r.stable_at_report) << r.joint;
  }
}

TEST(LoopModelPrediction, SearchKeepsTheRequiredMargin) {
  const LoopModel& m = ShippedModel();
  const SearchResult r = SearchGains(m, 2);
  for (int t = 0; t < 3; ++t) {
    const TypeGains& g = r.types[static_cast<std::size_t>(t)];
    if (g.stance_factor <= 0.0) continue;
    JointGains gains = m.gains;
    for (int leg = 0; leg < 4; ++leg) {
      gains.kp(3 * leg + t) *= g.stance_factor;
      gains.kd(3 * leg + t) *= g.stance_factor;
    }
    gains.swing_scale = g.swing_scale;
    for (int leg = 0; leg < 4; ++leg) {
      for (Phase ph : {Phase::kTrotStance, Phase::kStand}) {
        for (PlantKind pl : {PlantKind::kIdeal, PlantKind::kRealistic}) {
          EXPECT_GE(WorstExtraCycles(m, gains, 3 * leg + t, ph, pl, 10), 2) << t << " " << leg;
        }
      }
    }
    if (!g.swing_found) continue;
    for (int leg = 0; leg < 4; ++leg) {
      for (PlantKind pl : {PlantKind::kIdeal, PlantKind::kRealistic}) {
        EXPECT_GE(WorstExtraCycles(m, gains, 3 * leg + t, Phase::kSwing, pl, 10), 2) << t << " " << leg;
      }
    }
  }
}

}  // namespace
}  // namespace hyq::loop_model
