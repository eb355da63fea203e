// Closed-loop runs on the MuJoCo HyQ with the controllers the daemon runs (label sim).
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>

#include "config/hal_config_loader.h"
#include "config/servo_config_loader.h"
#include "dynamics/cycle_dynamics.h"
#include "servo/control/two_stage_id.h"
#include "tests/dynamics/hyq_fixture.h"
#include "tools/experiment/experiment.h"

namespace hyq::experiment {
namespace {

using servo::ControllerKind;
using testing::HyqModel;

ExperimentResult RunScenario(servo::Reference::Kind ref, ControllerKind kind, double mu, double seconds,
                     std::uint64_t seed = 1) {
  ExperimentConfig c;
  c.reference = ref;
  c.duration_s = seconds;
  c.mu = mu;
  c.controller = StandardController(kind);
  c.seed = seed;
  c.initial_perturbation_rad = 0.02;
  return RunExperiment(HyqModel(), c);
}

// Bound: the measured mean ‖q_ref − q‖ is 0.003 rad standing and 0.031–0.040 rad trotting
// (docs/experiments.md); twice that leaves room for numerical differences, while a controller
// that loses the reference (PID sags to 0.35–0.49 rad) fails it.
TEST(ClosedLoop, TwoStageIdStandsAndTrotsWithoutFalling) {
  const auto stand = RunScenario(servo::Reference::Kind::kStand, ControllerKind::kTwoStageId, 1.0, 1.0);
  EXPECT_FALSE(stand.fell);
  // from the 0.02 rad-per-joint initial perturbation the feet are planted where the standing
  // reference does not quite put them, so a residual of a few centiradians stays (measured
  // 0.032 rad); it must not grow
  EXPECT_LT(stand.mean_error_rad, 0.05);
  EXPECT_LT(stand.max_error_rad, 0.08);
  const auto trot = RunScenario(servo::Reference::Kind::kTrot, ControllerKind::kTwoStageId, 0.1, 2.5);
  EXPECT_FALSE(trot.fell);
  EXPECT_LT(trot.mean_error_rad, 0.08);
  EXPECT_EQ(trot.fallbacks.stage1_failed, 0u);
}

// "never fall back": 60 s of closed-loop trot on μ = 0.1 with the two-stage ID, then its
// 60 000 recorded ID problems solved again by a warm-started TwoStageId (as the loop does) and
// by a cold one (reset before every problem): no QP reaches its budget, so nothing falls back.
TEST(ClosedLoop, SixtySecondsOfTrotAndItsRecordedProblemsNeverFallBack) {
  ExperimentConfig c;
  c.reference = servo::Reference::Kind::kTrot;
  c.duration_s = 60.0;
  c.mu = 0.1;
  c.controller = StandardController(ControllerKind::kTwoStageId);
  c.record_id_inputs = true;
  const ExperimentResult r = RunExperiment(HyqModel(), c);
  EXPECT_FALSE(r.fell);
  EXPECT_EQ(r.fallbacks.stage1_failed + r.fallbacks.stage2_failed, 0u);
  ASSERT_GE(r.id_inputs.size(), 59'000u);
  servo::TwoStageId warm, cold;
  auto dyn = std::make_unique<dynamics::CycleDynamics>();
  std::size_t stage2_ran = 0;
  for (const servo::IdInput& in : r.id_inputs) {
    ASSERT_EQ(dynamics::ComputeCycleDynamics(HyqModel(), in.q, in.v, dyn.get()),
              dynamics::DynamicsStatus::kOk);
    servo::IdOutput ow, oc;
    cold.Reset();
    EXPECT_NE(warm.Solve(HyqModel(), *dyn, in, &ow), servo::IdStatus::kBadInput);
    EXPECT_NE(cold.Solve(HyqModel(), *dyn, in, &oc), servo::IdStatus::kBadInput);
    stage2_ran += oc.stage2.ran;
  }
  const servo::FallbackCounters& w = warm.counters();
  const servo::FallbackCounters& k = cold.counters();
  std::printf("%zu recorded problems (%zu with a Stage II): warm Stage I %llu, Stage II %llu "
              "fallbacks; cold Stage I %llu, Stage II %llu\n", r.id_inputs.size(), stage2_ran,
              static_cast<unsigned long long>(w.stage1_failed),
              static_cast<unsigned long long>(w.stage2_failed),
              static_cast<unsigned long long>(k.stage1_failed),
              static_cast<unsigned long long>(k.stage2_failed));
  EXPECT_EQ(w.stage1_failed + w.stage2_failed, 0u);
  EXPECT_EQ(k.stage1_failed + k.stage2_failed, 0u);
  EXPECT_GT(stage2_ran, r.id_inputs.size() / 2);
}

TEST(ClosedLoop, OnIceTheTwoStageIdSlipsLessThanTheNoSlipId) {
  const auto two = RunScenario(servo::Reference::Kind::kFigureEight, ControllerKind::kTwoStageId, 0.1, 2.5);
  const auto noslip = RunScenario(servo::Reference::Kind::kFigureEight, ControllerKind::kNoSlipId, 0.1, 2.5);
  std::printf("Figure-Eight, mu 0.1: mean stance-foot slip %.4f m/s (two-stage) vs %.4f m/s "
              "(no-slip); mean error %.4f vs %.4f rad\n", two.mean_slip_speed, noslip.mean_slip_speed,
              two.mean_error_rad, noslip.mean_error_rad);
  EXPECT_LT(two.mean_slip_speed, noslip.mean_slip_speed);
  EXPECT_LT(two.mean_error_rad, noslip.mean_error_rad);
}

// a trot from μ = 1 across an icy patch (μ = 0.1) and off it. With μ = 1 assumed the
// feet slide on the ice (measured 0.59-0.73 m/s on the patch, error 0.22-0.25 rad); with μ
// estimated online the robot walks across like with the true μ given (error within 20 % of the
// oracle's, measured +7 to +21 % per seed), and the estimate follows the ground.
TEST(ClosedLoop, EstimatedFrictionCrossesTheIcyPatchLikeTheOracle) {
  auto run = [](MuSource source) {
    ExperimentConfig c;
    c.reference = servo::Reference::Kind::kTrot;
    c.duration_s = 10.0;
    c.mu = 1.0;
    c.patches = {sim::GroundPatch{0.6, 1.2, -2.0, 2.0, 0.1}};
    c.mu_source = source;
    c.controller = StandardController(ControllerKind::kTwoStageId);
    c.initial_perturbation_rad = 0.02;
    return RunExperiment(HyqModel(), c);
  };
  const auto assumed = run(MuSource::kAssumed);
  const auto oracle = run(MuSource::kOracle);
  const auto estimated = run(MuSource::kEstimated);
  for (const auto* r : {&assumed, &oracle, &estimated})
    std::printf("on the patch: %ld cycles, mean error %.4f rad, stance slip %.4f m/s%s\n",
                r->patch_cycles, r->patch_mean_error_rad, r->patch_mean_slip_speed,
                r->fell ? ", FELL" : "");
  // the robot walked onto the patch with all four feet, and off it
  ASSERT_GT(estimated.patch_cycles, 3000);
  EXPECT_FALSE(estimated.fell);
  EXPECT_FALSE(oracle.fell);
  EXPECT_GT(assumed.patch_mean_slip_speed, 0.3);                     // (a) slides
  EXPECT_LT(estimated.patch_mean_slip_speed, 0.15 * assumed.patch_mean_slip_speed);
  EXPECT_LT(estimated.patch_mean_error_rad, 0.25 * assumed.patch_mean_error_rad);
  EXPECT_LT(estimated.patch_mean_error_rad, 1.3 * oracle.patch_mean_error_rad);
  // onto the ice each foot's estimate settles within its first footfall there that carries
  // weight on the ice (a foot whose centre crosses onto the patch at the end of a stance settles
  // in the next one), in a fraction of a second; off it, within 5 footfalls
  int onto = 0;
  for (const auto& st : estimated.settling) {
    std::printf("foot %d at %.2f s: mu %.2f -> %.2f, settled after %d footfalls, %.2f s\n", st.foot,
                st.t_s, st.from_mu, st.to_mu, st.footfalls, st.lag_s);
    if (st.to_mu < st.from_mu) {
      ++onto;
      EXPECT_GE(st.footfalls, 0) << "foot " << st.foot;
      EXPECT_LE(st.footfalls, 1) << "foot " << st.foot;
      EXPECT_LT(st.lag_s, 0.3) << "foot " << st.foot;
    } else if (st.t_s < 8.0) {  // later ones may run out of time
      EXPECT_GE(st.footfalls, 0) << "foot " << st.foot;
      EXPECT_LE(st.footfalls, 5) << "foot " << st.foot;
    }
  }
  EXPECT_EQ(onto, 4);
  for (const auto& smp : estimated.samples)
    for (int f = 0; f < 4; ++f) ASSERT_LE(smp.mu_control[static_cast<std::size_t>(f)], 1.0);
}

// on the `realistic` plant (model error, hydraulics, friction, delay, load-cell bias)
// the two-stage ID still trots on μ = 0.1 without falling, tracking worse than on the model
// (docs/simulation.md has the numbers; measured 6 s: 0.22 rad vs 0.027 rad).
TEST(ClosedLoop, RealisticPlantTrotsWithoutFalling) {
  ExperimentConfig c;
  c.reference = servo::Reference::Kind::kTrot;
  c.duration_s = 3.0;
  c.mu = 0.1;
  c.controller = StandardController(ControllerKind::kTwoStageId);
  c.profile = sim::PlantProfile::Realistic();
  const hal::HalConfig hal = config::LoadHalConfig(testing::SourceDir() / "config/hyq_hal.yaml");
  c.joints.assign(hal.joints.begin(), hal.joints.end());
  const ExperimentResult r = RunExperiment(HyqModel(), c);
  std::printf("realistic trot, two-stage ID, mu 0.1, 3 s: mean error %.4f rad, max %.4f, fell %d\n",
              r.mean_error_rad, r.max_error_rad, r.fell);
  EXPECT_FALSE(r.fell);
  EXPECT_LT(r.mean_error_rad, 0.4);
  // the applied torque is not the commanded one (actuators, delay)
  double differ = 0;
  for (const Sample& s : r.samples) differ = std::max(differ, (s.tau_applied - s.tau).cwiseAbs().maxCoeff());
  EXPECT_GT(differ, 1.0);
  // and without hydraulics the profile needs no calibration; with them it does
  c.joints.clear();
  EXPECT_THROW(RunExperiment(HyqModel(), c), std::invalid_argument);
}

// the trunk's disturbance observer finds a known payload (5 kg at (0.10, 0.05, 0.08) m
// in the trunk frame, on a plant otherwise the model) while the two-stage ID holds the robot
// standing: within 0.5 s the force is the payload's weight within 10 %, and after 2 s the moment
// about the base origin is the payload's within 10 % of m g times its lever. With the estimate in
// the controller's model the robot tracks better than without it; and with no payload it says
// (almost) nothing.
TEST(ClosedLoop, DisturbanceObserverFindsAPayload) {
  constexpr double kMass = 5.0, kG = 9.81;
  const Eigen::Vector3d p_B(0.10, 0.05, 0.08);
  ExperimentConfig c;
  c.reference = servo::Reference::Kind::kStand;
  c.duration_s = 2.0;
  c.mu = 1.0;
  c.controller = StandardController(ControllerKind::kTwoStageId);
  c.profile.model_error.payload_kg = kMass;
  c.profile.model_error.p_BoP_B = p_B;
  c.disturbance.enabled = true;
  const ExperimentResult on = RunExperiment(HyqModel(), c);
  ASSERT_FALSE(on.fell);
  double settled_at = -1.0;
  for (const Sample& s : on.samples) {
    const bool within = std::abs(-s.disturbance(2) - kMass * kG) <= 0.1 * kMass * kG;
    if (within && settled_at < 0) settled_at = s.t;
    if (!within) settled_at = -1.0;  // the first time it stays within 10 % to the end
  }
  const Sample& last = on.samples.back();
  // the weight's moment about the base origin in the base frame (the trunk stays level: R ≈ I)
  const Eigen::Vector3d n = p_B.cross(Eigen::Vector3d(0, 0, -kMass * kG));
  std::printf("payload 5 kg: force z %.2f N (weight %.2f N), settled within 10 %% at %.3f s; "
              "moment %.2f %.2f %.2f N·m (expected %.2f %.2f %.2f)\n",
              last.disturbance(2), -kMass * kG, settled_at, last.disturbance(3), last.disturbance(4),
              last.disturbance(5), n.x(), n.y(), n.z());
  EXPECT_GE(settled_at, 0.0);
  EXPECT_LE(settled_at, 0.5);
  for (int k = 0; k < 2; ++k)
    EXPECT_NEAR(last.disturbance(3 + k), n(k), 0.10 * kMass * kG * p_B.head<2>().norm()) << k;
  // with the estimate in the model, the standing robot tracks better than without it
  c.disturbance.enabled = false;
  const ExperimentResult off = RunExperiment(HyqModel(), c);
  std::printf("payload 5 kg, standing: mean error %.5f rad with the observer, %.5f rad without\n",
              on.mean_error_rad, off.mean_error_rad);
  EXPECT_LT(on.mean_error_rad, 0.8 * off.mean_error_rad);
  // no payload: the model explains the robot, the estimate stays small
  c.disturbance.enabled = true;
  c.profile.model_error.payload_kg = 0.0;
  const ExperimentResult none = RunExperiment(HyqModel(), c);
  EXPECT_LT(std::abs(none.samples.back().disturbance(2)), 0.02 * kMass * kG);
}

// ... and costs the trot nothing: with the shipped (tuned) gains, 10 s of trot on μ = 0.1, the
// two-stage ID's mean error with the observer is within 2 % of its error without it, on the ideal
// and on the realistic plant (measured 2026-12-04: +0.5 % and −2.5 %; the 18-row residual
// filtered and then split cost +10.5 % and +1.4 %: docs/baselines.md)
TEST(ClosedLoop, DisturbanceObserverDoesNotCostTheTrot) {
  const hal::HalConfig hal = config::LoadHalConfig(testing::SourceDir() / "config/hyq_hal.yaml");
  const servo::ControllerConfig shipped =
      config::LoadServoConfig((testing::SourceDir() / "config/hyq_servo_sim.yaml").string()).controller;
  for (const bool realistic : {false, true}) {
    double error[2];
    for (const bool on : {false, true}) {
      ExperimentConfig c;
      c.reference = servo::Reference::Kind::kTrot;
      c.duration_s = 10.0;
      c.mu = 0.1;
      c.seed = 1;
      c.initial_perturbation_rad = 0.02;
      c.controller = StandardController(ControllerKind::kTwoStageId);
      c.controller.feedback = shipped.feedback;
      c.controller.swing_gain_scale = shipped.swing_gain_scale;
      if (realistic) c.profile = sim::PlantProfile::Realistic();
      c.joints.assign(hal.joints.begin(), hal.joints.end());
      c.disturbance.enabled = on;
      const ExperimentResult r = RunExperiment(HyqModel(), c);
      ASSERT_FALSE(r.fell);
      error[on] = r.mean_error_rad;
    }
    std::printf("%s trot, mu 0.1, shipped gains: mean error %.5f rad without the observer, %.5f "
                "with it (%+.1f %%)\n", realistic ? "realistic" : "ideal", error[0], error[1],
                100.0 * (error[1] / error[0] - 1.0));
    EXPECT_LE(error[1], 1.02 * error[0]) << (realistic ? "realistic" : "ideal");
  }
}

TEST(ClosedLoop, SameSeedSameRun) {
  const auto a = RunScenario(servo::Reference::Kind::kTrot, ControllerKind::kTwoStageId, 0.1, 1.0, 7);
  const auto b = RunScenario(servo::Reference::Kind::kTrot, ControllerKind::kTwoStageId, 0.1, 1.0, 7);
  ASSERT_EQ(a.samples.size(), b.samples.size());
  for (std::size_t k = 0; k < a.samples.size(); ++k) {
    ASSERT_EQ(a.samples[k].q, b.samples[k].q) << k;
    ASSERT_EQ(a.samples[k].tau, b.samples[k].tau) << k;
  }
  const auto c = RunScenario(servo::Reference::Kind::kTrot, ControllerKind::kTwoStageId, 0.1, 1.0, 8);
  EXPECT_NE(a.samples.back().q, c.samples.back().q);  // the seed matters
}

}  // namespace
}  // namespace hyq::experiment
