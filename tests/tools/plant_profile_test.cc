// A plant that is not the model: the perturbed model differs from the nominal
// one by what was asked, HyQ's hydraulic torque loop has its documented bandwidth, and friction,
// delay, biases and the profiles behave as configured (label sim).
#include <cmath>
#include <cstdio>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "config/hal_config_loader.h"
#include "tests/dynamics/hyq_fixture.h"
#include "tests/support/no_heap_guard.h"
#include "tools/experiment/experiment.h"
#include "sim/hydraulic_actuator.h"
#include "sim/plant.h"
#include "sim/plant_profile.h"

namespace hyq::sim {
namespace {

using testing::HyqModel;

const hal::HalConfig& Hal() {
  static const hal::HalConfig c = config::LoadHalConfig(testing::SourceDir() / "config/hyq_hal.yaml");
  return c;
}

// MuJoCo's joint-space inertia (mj_fullM) of a plant at q
Eigen::MatrixXd MassMatrix(Plant& plant, const dynamics::VectorQ& q) {
  plant.Reset(q, dynamics::VectorV::Zero());
  const mjModel* m = plant.mj_model();
  Eigen::Matrix<mjtNum, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> M(m->nv, m->nv);
  mj_fullM(m, M.data(), plant.mj_data()->qM);
  return M;
}

dynamics::VectorQ TiltedPosture() {
  dynamics::VectorQ q = HyqModel().StandingQ();
  const Eigen::Quaterniond r(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  q.segment<4>(3) << r.w(), r.x(), r.y(), r.z();
  q.tail<12>() += 0.1 * dynamics::VectorJ::LinSpaced(-1.0, 1.0);
  return q;
}

Eigen::Matrix3d Skew(const Eigen::Vector3d& p) {
  Eigen::Matrix3d S;
  S << 0, -p.z(), p.y(), p.z(), 0, -p.x(), -p.y(), p.x(), 0;
  return S;
}

// A payload alone changes M by exactly the point mass's m JᵀJ, where J maps MuJoCo's free-joint
// velocity (world linear, body angular) to the payload's world velocity: v + R (ω_B × p) =
// [I, −R [p]×] (v, ω_B). Nothing outside the base block changes.
TEST(PerturbedModel, APayloadChangesTheMassMatrixByItsSpatialInertia) {
  const dynamics::VectorQ q = TiltedPosture();
  PlantConfig nominal_cfg, payload_cfg;
  payload_cfg.model_error.payload_kg = 5.0;
  payload_cfg.model_error.p_BoP_B = Eigen::Vector3d(0.10, 0.05, 0.08);
  Plant nominal(HyqModel(), nominal_cfg), loaded(HyqModel(), payload_cfg);
  const Eigen::MatrixXd dM = MassMatrix(loaded, q) - MassMatrix(nominal, q);
  const Eigen::Matrix3d R =
      Eigen::Quaterniond(q(3), q(4), q(5), q(6)).normalized().toRotationMatrix();
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(3, dynamics::kNv);
  J.leftCols<3>() = Eigen::Matrix3d::Identity();
  J.block<3, 3>(0, 3) = -R * Skew(payload_cfg.model_error.p_BoP_B);
  const Eigen::MatrixXd expected = 5.0 * J.transpose() * J;
  // MuJoCo diagonalises each body's inertia at compile time (mju_eig3, iterative, converged to
  // ~1e-7 of the tensor), so the rotational block agrees to that, the rest to rounding
  const double tol = 2e-7 * MassMatrix(nominal, q).block<3, 3>(3, 3).norm();
  EXPECT_LT((dM - expected).cwiseAbs().maxCoeff(), tol) << "ΔM\n" << dM << "\nexpected\n" << expected;
  EXPECT_LT((dM - expected).leftCols<3>().cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(dM(0, 0), 5.0, 1e-12);
}

// Per-link errors: the total mass (M's translational block) changes by exactly the sum of the
// drawn mass errors (plus the payload), each draw within the asked level, the same seed gives
// the same model and another seed another one.
TEST(PerturbedModel, LinkErrorsStayWithinTheAskedLevelsAndAddUpInTheMassMatrix) {
  ModelErrorConfig e;
  e.link_errors = true;
  e.seed = 7;
  e.payload_kg = 3.0;
  e.p_BoP_B = Eigen::Vector3d(-0.2, 0.0, 0.05);
  const dynamics::Model& nom = HyqModel();
  const dynamics::Model per = PerturbModel(nom, e);
  double sum_dm = 0, max_rel_m = 0, max_dc = 0, max_rel_i = 0;
  for (int b = 0; b < dynamics::kNumBodies; ++b) {
    const auto& a = nom.bodies[b].inertia;
    const auto& p = per.bodies[b].inertia;
    if (b == dynamics::kTrunk) continue;  // the payload is lumped in; checked through the total
    sum_dm += p.mass - a.mass;
    max_rel_m = std::max(max_rel_m, std::abs(p.mass / a.mass - 1));
    max_dc = std::max(max_dc, (p.p_BoBcm_B - a.p_BoBcm_B).cwiseAbs().maxCoeff());
    max_rel_i = std::max(max_rel_i, std::abs(p.I_Bcm_B.trace() / a.I_Bcm_B.trace() - 1));
  }
  EXPECT_LE(max_rel_m, 0.05);
  EXPECT_LE(max_dc, 0.01);
  EXPECT_LE(max_rel_i, 0.10 + 1e-12);
  // the draws use the range (12 uniform draws each: the largest is near the bound)
  EXPECT_GT(max_rel_m, 0.025);
  EXPECT_GT(max_dc, 0.005);
  EXPECT_GT(max_rel_i, 0.05);
  // the trunk's own mass error, recovered from the lumped payload
  ModelErrorConfig no_payload = e;
  no_payload.payload_kg = 0.0;
  const double trunk_dm =
      PerturbModel(nom, no_payload).bodies[dynamics::kTrunk].inertia.mass - nom.bodies[dynamics::kTrunk].inertia.mass;
  EXPECT_LE(std::abs(trunk_dm / nom.bodies[dynamics::kTrunk].inertia.mass), 0.05);
  sum_dm += trunk_dm;

  PlantConfig c0, c1;
  c1.model_error = e;
  Plant nominal(nom, c0), perturbed(nom, c1);
  const dynamics::VectorQ q = TiltedPosture();
  const Eigen::MatrixXd M0 = MassMatrix(nominal, q), M1 = MassMatrix(perturbed, q);
  EXPECT_NEAR(M1(0, 0) - M0(0, 0), e.payload_kg + sum_dm, 1e-9);
  EXPECT_NEAR(M0(0, 0), nom.TotalMass(), 1e-9);
  EXPECT_NEAR(M1(0, 0), per.TotalMass(), 1e-9);
  // the joint block changes too (link inertias), by at most the asked relative levels' order
  const double rel = (M1 - M0).bottomRightCorner<12, 12>().norm() / M0.bottomRightCorner<12, 12>().norm();
  EXPECT_GT(rel, 1e-3);
  EXPECT_LT(rel, 0.3);

  const dynamics::Model again = PerturbModel(nom, e);
  ModelErrorConfig other = e;
  other.seed = 8;
  const dynamics::Model different = PerturbModel(nom, other);
  EXPECT_EQ(again.bodies[5].inertia.mass, per.bodies[5].inertia.mass);
  EXPECT_NE(different.bodies[5].inertia.mass, per.bodies[5].inertia.mass);
  // and the plant's MJCF (hyq-sim --write-model) carries it
  EXPECT_NE(perturbed.mjcf(), nominal.mjcf());
}

TEST(PerturbedModel, BadLevelsAreRefused) {
  ModelErrorConfig e;
  e.payload_kg = -1.0;
  EXPECT_THROW(PerturbModel(HyqModel(), e), std::invalid_argument);
  e.payload_kg = 0.0;
  e.mass_rel = 1.5;
  EXPECT_THROW(PerturbModel(HyqModel(), e), std::invalid_argument);
}

// --- hydraulics --------------------------------------------------------------------------------

constexpr double kStep = 1e-3;
// docs/simulation.md, "Hydraulic actuators": the closed-loop torque bandwidth with the leg
// clamped that the board's gains are set for
constexpr double kCylinderBandwidthHz = 80.0;
constexpr double kHaaBandwidthHz = 80.0;

HydraulicActuator MakeActuator(int joint, const HydraulicParams& p = {}) {
  const auto& lim = HyqModel().limits[static_cast<std::size_t>(joint)];
  return HydraulicActuator(p, Hal().joints[static_cast<std::size_t>(joint)], lim.lower_rad,
                           lim.upper_rad, kStep, HyqModel().joint_names[static_cast<std::size_t>(joint)]);
}

// Closed-loop gain |τ / τ_ref| at f with the joint held at q (the leg clamped): a sine of
// `amp` N·m about `bias` N·m, the amplitude of the response's fundamental over whole periods
// after a settling period.
double Gain(int joint, double f_hz, double amp = 20.0, double bias = 20.0) {
  HydraulicActuator a = MakeActuator(joint);
  const double q = HyqModel().q_standing(joint);
  a.Reset(q, bias);
  const int per_period = static_cast<int>(std::lround(1.0 / (f_hz * kStep)));
  const int periods = std::max(4, static_cast<int>(std::ceil(0.2 * f_hz)));
  double s = 0, c = 0;
  for (int k = 0; k < (periods + 2) * per_period; ++k) {
    const double t = k * kStep;
    a.Step(bias + amp * std::sin(2 * M_PI * f_hz * t), q, 0.0);
    if (k >= 2 * per_period) {
      const double tt = t + kStep;  // torque_Nm() is at the end of the step
      s += (a.torque_Nm() - bias) * std::sin(2 * M_PI * f_hz * tt);
      c += (a.torque_Nm() - bias) * std::cos(2 * M_PI * f_hz * tt);
    }
  }
  const double n = periods * per_period;
  return 2.0 * std::hypot(s, c) / n / amp;
}

// The −3 dB frequency of Gain, by bisection on a monotone part of the curve.
double Bandwidth(int joint) {
  double lo = 2.0, hi = 400.0;
  for (int i = 0; i < 30; ++i) {
    const double mid = std::sqrt(lo * hi);
    (Gain(joint, mid) > std::sqrt(0.5) ? lo : hi) = mid;
  }
  return std::sqrt(lo * hi);
}

// The documented closed-loop torque bandwidth (docs/simulation.md) with the leg clamped, per
// actuator kind: the torque loop's gains are set for it; ±15 % covers the lever arm's change
// over the standing posture's joints.
TEST(Hydraulics, TorqueLoopHasTheDocumentedBandwidth) {
  for (int j : {0, 1, 2, 4, 5}) {
    const double bw = Bandwidth(j);
    std::printf("%s: closed-loop torque bandwidth %.1f Hz, gain at 5 Hz %.3f\n",
                HyqModel().joint_names[static_cast<std::size_t>(j)].c_str(), bw, Gain(j, 5.0));
    const double documented = j % 3 == 0 ? kHaaBandwidthHz : kCylinderBandwidthHz;
    EXPECT_NEAR(bw, documented, 0.15 * documented) << HyqModel().joint_names[static_cast<std::size_t>(j)];
    EXPECT_NEAR(Gain(j, 5.0), 1.0, 0.05);
  }
}

// A 40 N·m step with the leg clamped: settles within 2 % of the set-point, overshoot bounded,
// 90 % reached within a few of the loop's time constants.
TEST(Hydraulics, StepResponseSettlesWithBoundedOvershoot) {
  for (int j : {0, 1, 2}) {
    HydraulicActuator a = MakeActuator(j);
    const double q = HyqModel().q_standing(j);
    a.Reset(q, 0.0);
    double peak = 0, t90 = -1;
    std::vector<double> tau;
    for (int k = 0; k < 300; ++k) {
      a.Step(40.0, q, 0.0);
      tau.push_back(a.torque_Nm());
      peak = std::max(peak, a.torque_Nm());
      if (t90 < 0 && a.torque_Nm() >= 36.0) t90 = (k + 1) * kStep;
    }
    const double overshoot = (peak - 40.0) / 40.0;
    std::printf("%s: step 0 -> 40 N·m: 90 %% after %.1f ms, overshoot %.1f %%, final %.3f N·m\n",
                HyqModel().joint_names[static_cast<std::size_t>(j)].c_str(), 1e3 * t90,
                100 * overshoot, tau.back());
    EXPECT_LT(overshoot, 0.10);
    EXPECT_NEAR(tau.back(), 40.0, 0.8);
    EXPECT_GT(t90, 0.0);
    EXPECT_LT(t90, 0.025);
  }
}

// More than the supply pressure can give: the torque saturates at p_s A r(q), not beyond.
TEST(Hydraulics, TorqueSaturatesAtTheSupplyPressure) {
  HydraulicActuator a = MakeActuator(2);
  const double q = HyqModel().q_standing(2);
  a.Reset(q, 0.0);
  const double limit = a.MaxTorqueNm(q, false);
  for (int k = 0; k < 500; ++k) a.Step(-1000.0, q, 0.0);
  EXPECT_LT(std::abs(a.torque_Nm()), limit * 1.0001);
  EXPECT_GT(std::abs(a.torque_Nm()), limit * 0.9);
  std::printf("lf_kfe at q %.2f: %.1f N·m pulling max, %.1f N·m pushing max\n", q,
              a.MaxTorqueNm(q, false), a.MaxTorqueNm(q, true));
}

// Moving joint: velocity compensation keeps the torque close to the set-point while the joint
// moves at 2 rad/s (without it, the motion's flow demand drops the force), after the first 50 ms.
TEST(Hydraulics, VelocityCompensationHoldsTheTorqueWhileTheJointMoves) {
  auto run = [](bool comp) {
    HydraulicParams p;
    p.velocity_compensation = comp;
    HydraulicActuator a = MakeActuator(1, p);
    double q = HyqModel().q_standing(1) - 0.2;
    a.Reset(q, 30.0);
    double worst = 0;
    for (int k = 0; k < 200; ++k) {
      a.Step(30.0, q, 2.0);
      q += 2.0 * kStep;
      if (k >= 50) worst = std::max(worst, std::abs(a.torque_Nm() - 30.0));
    }
    return worst;
  };
  const double with = run(true), without = run(false);
  std::printf("lf_hfe at 2 rad/s: worst torque error %.2f N·m with velocity compensation, %.2f without\n",
              with, without);
  EXPECT_LT(with, 0.1 * without);
}

// A board whose outputs are off drives no valve current: the spool centres, the ports close and
// the joint is hydraulically locked. A knee carrying 80 N·m of load (a trunk share on a 1-DOF
// inertia) creeps by the lands' leakage alone, in the direction of the load and slowly, about as
// fast as LockDamping (what the profiles without hydraulics apply) says; with the outputs on and
// a zero set-point the same joint gives way at once.
TEST(Hydraulics, AnOffBoardLocksItsJointWhichCreepsByTheLandsLeakage) {
  constexpr int kKnee = 2;
  constexpr double kInertia = 0.5, kLoadNm = -80.0;  // kg·m², N·m
  auto run = [&](bool on, double* mean_qd) {
    HydraulicActuator a = MakeActuator(kKnee);
    double q = HyqModel().q_standing(kKnee), qd = 0.0;
    a.Reset(q, -kLoadNm);
    double sum = 0.0, fastest = 0.0;
    int n = 0;
    for (int k = 0; k < 1500; ++k) {
      const double tau = a.Step(0.0, q, qd, on);
      qd += kStep * (tau + kLoadNm) / kInertia;
      q += kStep * qd;
      fastest = std::max(fastest, std::abs(qd));
      if (k >= 500) {
        sum += qd;
        ++n;
      }
    }
    *mean_qd = sum / n;
    return fastest;
  };
  double locked_qd = 0, limp_qd = 0;
  const double locked_peak = run(false, &locked_qd), limp_peak = run(true, &limp_qd);
  HydraulicActuator a = MakeActuator(kKnee);
  const double b = a.LockDamping(HyqModel().q_standing(kKnee));
  std::printf("lf_kfe under %.0f N·m: locked creep %.3f rad/s (peak %.3f), LockDamping %.0f N·m·s/rad "
              "(%.3f rad/s); outputs on at 0 N·m: peak %.1f rad/s; land leakage %.3g m³/(s·Pa)\n",
              kLoadNm, locked_qd, locked_peak, b, kLoadNm / b, limp_peak, a.land_leakage());
  EXPECT_LT(locked_qd, 0.0);                  // with the load
  EXPECT_LT(locked_peak, 0.5);                // held: no fall
  EXPECT_GT(limp_peak, 10.0 * locked_peak);   // a torque loop at 0 N·m gives way
  EXPECT_GT(b, 100.0);
  EXPECT_LT(std::abs(locked_qd), 3.0 * std::abs(kLoadNm) / b);
}

TEST(Hydraulics, BadParametersAreRefused) {
  HydraulicParams p;
  p.supply_pressure_Pa = -1;
  EXPECT_THROW(MakeActuator(1, p), std::invalid_argument);
  p = {};
  p.substeps = 7;  // not a multiple of the loop's updates per step? (1: fine) -> dead volume
  p.dead_volume_m3 = 0;
  EXPECT_THROW(MakeActuator(1, p), std::invalid_argument);
}

// --- friction, delay, biases, profiles --------------------------------------------------------

TEST(JointFriction, CoulombPlusViscousAsConfiguredAndAppliedByThePlant) {
  JointFrictionConfig f;
  f.enabled = true;
  f.coulomb_Nm = {1.0, 2.0, 3.0};
  f.viscous_Nm_s = {0.1, 0.2, 0.3};
  f.band_rad_s = 0.01;
  EXPECT_EQ(f.Torque(4, 0.0), 0.0);
  EXPECT_NEAR(f.Torque(4, 1.0), -(2.0 + 0.2), 1e-9);  // lf... rf_hfe: type hfe
  EXPECT_NEAR(f.Torque(5, -2.0), 3.0 + 0.6, 1e-9);
  EXPECT_NEAR(f.Torque(0, 0.005), -1.0 * std::tanh(0.5) - 0.0005, 1e-12);
  f.enabled = false;
  EXPECT_EQ(f.Torque(4, 1.0), 0.0);
  f.enabled = true;

  PlantConfig pc;
  pc.joint_friction = f;
  Plant plant(HyqModel(), pc);
  dynamics::VectorV v = dynamics::VectorV::Zero();
  v.tail<12>() = dynamics::VectorJ::LinSpaced(-1.5, 1.5);
  plant.Reset(HyqModel().StandingQ(), v);
  plant.Step(dynamics::VectorJ::Zero());
  for (int j = 0; j < 12; ++j)
    EXPECT_DOUBLE_EQ(plant.mj_data()->qfrc_applied[6 + j], f.Torque(j, v(6 + j))) << j;
}

TEST(Actuation, TheSetPointTakesEffectKCyclesLater) {
  for (int k : {0, 1, 3}) {
    PlantProfile p;
    p.delay_cycles = k;
    Actuation a(HyqModel(), {}, p, 0.0, 0.0, kStep);
    a.Reset(HyqModel().q_standing);
    const dynamics::VectorJ q = HyqModel().q_standing, qd = dynamics::VectorJ::Zero();
    for (int step = 0; step < 6; ++step) {
      const dynamics::VectorJ u = dynamics::VectorJ::Constant(step == 1 ? 10.0 : 0.0);
      a.Step(u, q, qd);
      EXPECT_EQ(a.applied_Nm()(3), step == 1 + k ? 10.0 : 0.0) << "k " << k << " step " << step;
    }
  }
  PlantProfile bad;
  bad.delay_cycles = kMaxDelayCycles + 1;
  EXPECT_THROW(Actuation(HyqModel(), {}, bad, 0.0, 0.0, kStep), std::invalid_argument);
}

TEST(Actuation, LoadCellBiasWithinItsLevelAndFixedBySeed) {
  PlantProfile p;
  p.load_cell_bias_Nm = 1.5;
  p.bias_seed = 3;
  Actuation a(HyqModel(), {}, p, 0.0, 0.0, kStep);
  a.Reset(HyqModel().q_standing);
  const dynamics::VectorJ u = dynamics::VectorJ::LinSpaced(-20, 20);
  a.Step(u, HyqModel().q_standing, dynamics::VectorJ::Zero());
  const auto biases = p.LoadCellBiases();
  double largest = 0;
  for (int j = 0; j < 12; ++j) {
    EXPECT_EQ(a.applied_Nm()(j), u(j));
    EXPECT_NEAR(a.measured_Nm()(j) - a.applied_Nm()(j), biases[static_cast<std::size_t>(j)], 1e-12);
    EXPECT_LE(std::abs(biases[static_cast<std::size_t>(j)]), 1.5);
    largest = std::max(largest, std::abs(biases[static_cast<std::size_t>(j)]));
  }
  EXPECT_GT(largest, 0.75);
  EXPECT_EQ(p.LoadCellBiases(), biases);
  PlantProfile other = p;
  other.bias_seed = 4;
  EXPECT_NE(other.LoadCellBiases(), biases);
  EXPECT_LE(PlantProfile::Realistic().GyroBias().cwiseAbs().maxCoeff(),
            PlantProfile::Realistic().gyro_bias_rad_s);
}

// A board with its outputs off applies nothing; without the hydraulics its joint gets the lock's
// damping (from the calibrations; none without them), with them the valve itself locks it.
TEST(Actuation, ABoardWithItsOutputsOffLocksItsJoint) {
  const dynamics::VectorJ q = HyqModel().q_standing, qd = dynamics::VectorJ::Zero();
  const dynamics::VectorJ u = dynamics::VectorJ::Constant(10.0);
  std::array<bool, dynamics::kNumJoints> on;
  on.fill(true);
  on[2] = on[3] = false;
  for (const double lag : {0.0, 0.01}) {
    Actuation a(HyqModel(), Hal().joints, PlantProfile::Ideal(), lag, 0.0, kStep);
    a.Reset(q);
    a.Step(u, on, q, qd);
    for (int j = 0; j < dynamics::kNumJoints; ++j) {
      const bool off = j == 2 || j == 3;
      EXPECT_EQ(a.applied_Nm()(j) == 0.0, off) << j;
      EXPECT_EQ(a.lock_damping_Nms()(j) > 100.0, off) << j;
    }
    EXPECT_DOUBLE_EQ(a.lock_damping_Nms()(2), MakeActuator(2).LockDamping(q(2)));
    // a leg swinging at 8 rad/s when its valve closes: no more than the relief valve's torque
    const dynamics::VectorJ fast = dynamics::VectorJ::Constant(8.0);
    a.Step(u, on, q, fast);
    const double limit = MakeActuator(2).LockTorqueLimitNm(q(2));
    EXPECT_NEAR(a.lock_damping_Nms()(2) * 8.0, limit, 1e-9 * limit);
    EXPECT_GT(limit, 100.0);
    EXPECT_LT(limit, 500.0);
  }
  Actuation none(HyqModel(), {}, PlantProfile::Ideal(), 0.0, 0.0, kStep);
  none.Step(u, on, q, qd);
  EXPECT_EQ(none.lock_damping_Nms().cwiseAbs().maxCoeff(), 0.0);
  PlantProfile realistic = PlantProfile::Realistic();
  realistic.delay_cycles = 0;  // off from the first step
  Actuation hyd(HyqModel(), Hal().joints, realistic, 0.0, 0.0, kStep);
  Actuation other(HyqModel(), Hal().joints, realistic, 0.0, 0.0, kStep);
  hyd.Reset(q);
  other.Reset(q);
  for (int k = 0; k < 50; ++k) {
    hyd.Step(u, on, q, qd);
    other.Step(-u, on, q, qd);
  }
  // the locked joint's torque is the oil's, whatever its set-point
  EXPECT_EQ(hyd.applied_Nm()(2), other.applied_Nm()(2));
  EXPECT_NEAR(other.applied_Nm()(1), -10.0, 0.5);
  EXPECT_EQ(hyd.lock_damping_Nms().cwiseAbs().maxCoeff(), 0.0);  // the valve model locks it
  EXPECT_LT(std::abs(hyd.hydraulic(2)->spool()), 1e-6);           // centred
  EXPECT_NEAR(hyd.applied_Nm()(1), 10.0, 0.5);                    // the torque loop at work
  // the pump off: nothing locks a joint whose board is off
  PlantProfile off = PlantProfile::Ideal();
  off.pump_on = false;
  Actuation free(HyqModel(), Hal().joints, off, 0.0, 0.0, kStep);
  free.Step(u, on, q, qd);
  EXPECT_EQ(free.lock_damping_Nms().cwiseAbs().maxCoeff(), 0.0);
}

TEST(Actuation, HydraulicStepAllocatesNothing) {
  Actuation a(HyqModel(), Hal().joints, PlantProfile::Realistic(), 0.0, 0.0, kStep);
  a.Reset(HyqModel().q_standing);
  const dynamics::VectorJ u = dynamics::VectorJ::Constant(10.0), qd = dynamics::VectorJ::Zero();
  a.Step(u, HyqModel().q_standing, qd);
  {
    testing::NoHeapGuard guard;
    for (int k = 0; k < 10; ++k) a.Step(u, HyqModel().q_standing, qd);
  }
  EXPECT_TRUE(std::isfinite(a.applied_Nm().sum()));
}

TEST(PlantProfile, NamesAndBadNames) {
  EXPECT_EQ(ProfileByName("ideal", "--profile").name, "ideal");
  const PlantProfile r = ProfileByName("realistic", "--profile");
  EXPECT_TRUE(r.hydraulics);
  EXPECT_TRUE(r.joint_friction.enabled);
  EXPECT_TRUE(r.model_error.link_errors);
  EXPECT_GT(r.model_error.payload_kg, 0.0);
  EXPECT_GE(r.delay_cycles, 1);
  try {
    ProfileByName("fancy", "--profile");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "--profile: expected a plant profile ideal or realistic, found 'fancy'");
  }
  // ideal is today's plant: nothing differs
  const PlantProfile i = PlantProfile::Ideal();
  EXPECT_FALSE(i.hydraulics || i.joint_friction.enabled || i.model_error.link_errors);
  EXPECT_EQ(i.model_error.payload_kg, 0.0);
  EXPECT_EQ(i.delay_cycles, 0);
  EXPECT_EQ(i.load_cell_bias_Nm + i.gyro_bias_rad_s + i.accel_bias_m_s2, 0.0);
}

}  // namespace
}  // namespace hyq::sim
