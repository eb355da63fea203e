// The control pipeline (servo/runtime/control_pipeline.h): friction estimate → disturbance
// observer → controller gives, bit for bit, what the stages give when assembled by hand with the
// observer's wrench subtracted from the model's h in place (the independent reference), leaves
// the cycle's dynamics as they were, and allocates nothing after a warm-up.
#include <memory>
#include <random>

#include <gtest/gtest.h>

#include "servo/runtime/control_pipeline.h"
#include "tests/servo/id_fixture.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::servo {
namespace {

using dynamics::CycleDynamics;
using testing::HyqModel;

constexpr double kDt = 1e-3;
constexpr std::array<bool, kNumFeet> kAll{true, true, true, true};
constexpr std::array<bool, kNumFeet> kLfRh{true, false, false, true};

ControllerConfig Gains(ControllerKind kind) {
  ControllerConfig c;
  c.kind = kind;
  c.feedback.kp_tau.setConstant(300.0);
  c.feedback.kd_tau.setConstant(8.0);
  c.pd_gravity.kp.setConstant(300.0);
  c.pd_gravity.kd.setConstant(8.0);
  return c;
}

FrictionEstimatorConfig FrictionOn() {
  FrictionEstimatorConfig f;
  f.enabled = true;
  return f;
}

DisturbanceObserverConfig ObserverOn() {
  DisturbanceObserverConfig d;
  d.enabled = true;
  return d;
}

// One cycle's measured state: near standing, moving a little, with load-cell torques that
// leave the model a residual for the observer to find
struct Cycle {
  IdInput in;
  std::unique_ptr<CycleDynamics> dyn = std::make_unique<CycleDynamics>();
  VectorJ tau_measured;
  JointReference ref;
};

Cycle MakeCycle(std::mt19937_64* rng, const std::array<bool, kNumFeet>& stance) {
  Cycle c;
  c.in = testing::StandingInput(rng, stance);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < dynamics::kNv; ++i) c.in.v(i) = 0.1 * u(*rng);
  EXPECT_EQ(dynamics::ComputeCycleDynamics(HyqModel(), c.in.q, c.in.v, c.dyn.get()),
            dynamics::DynamicsStatus::kOk);
  c.tau_measured = c.dyn->bias.tail<kNumJoints>();
  for (int j = 0; j < kNumJoints; ++j) c.tau_measured(j) += 20.0 * u(*rng);
  c.ref.q = HyqModel().q_standing;
  c.ref.stance = stance;
  return c;
}

TEST(ControlPipeline, SameAsTheStagesAssembledByHand) {
  std::mt19937_64 rng(7);
  std::vector<Cycle> cycles;
  for (int k = 0; k < 40; ++k) cycles.push_back(MakeCycle(&rng, k % 10 < 5 ? kAll : kLfRh));
  ContactEnvironment ceiling;
  ceiling.mu = {0.8, 0.6, 1.0, 0.7};
  for (ControllerKind kind : {ControllerKind::kTwoStageId, ControllerKind::kStage1Id,
                              ControllerKind::kNoSlipId, ControllerKind::kPdGravity,
                              ControllerKind::kPid}) {
    ControlPipeline pipeline(HyqModel(), Gains(kind), FrictionOn(), ObserverOn(), kDt);
    // the reference: the stages by hand, the observer's wrench subtracted from a copy of h
    Controller ctl(HyqModel(), Gains(kind));
    FrictionEstimator friction(FrictionOn());
    DisturbanceObserver observer(HyqModel(), ObserverOn(), kDt);
    auto scratch = std::make_unique<CycleDynamics>();
    for (const Cycle& c : cycles) {
      const VectorV bias_before = c.dyn->bias;
      IdOutput a;
      const IdStatus sa = pipeline.Compute(*c.dyn, c.in.q, c.in.v, c.tau_measured, c.ref.stance,
                                           kAll, c.ref, ceiling, &a);
      EXPECT_EQ(c.dyn->bias, bias_before) << "the pipeline changed the cycle's dynamics";

      std::array<FootFrictionInput, kNumFeet> feet;
      for (int f = 0; f < kNumFeet; ++f)
        feet[static_cast<std::size_t>(f)] =
            MeasureFoot(HyqModel(), *c.dyn, c.in.v, f, c.ref.stance[static_cast<std::size_t>(f)],
                        c.tau_measured.segment<3>(3 * f));
      friction.Update(feet, kAll, ceiling.mu, kDt);
      ContactEnvironment env = ceiling;
      for (std::size_t f = 0; f < kNumFeet; ++f) env.mu[f] = friction.feet()[f].mu_control;
      *scratch = *c.dyn;
      scratch->bias.head<dynamics::kNumBaseDofs>() -= observer.Update(*c.dyn, c.in.v, c.tau_measured);
      IdOutput b;
      const IdStatus sb = ctl.Compute(*scratch, c.in.q, c.in.v, c.ref, env, kDt, &b);

      EXPECT_EQ(sa, sb) << ToString(kind);
      EXPECT_EQ(a.tau_Nm, b.tau_Nm) << ToString(kind);
      EXPECT_EQ(pipeline.environment().mu, env.mu);
      EXPECT_EQ(pipeline.disturbance().wrench(), observer.wrench());
    }
    EXPECT_NE(pipeline.disturbance().wrench(), dynamics::Vector6d::Zero()) << "observer unused";
  }
}

TEST(ControlPipeline, WithTheEstimatorsOffTheControllerGetsTheCeiling) {
  std::mt19937_64 rng(3);
  const Cycle c = MakeCycle(&rng, kAll);
  ContactEnvironment ceiling;
  ceiling.mu = {0.3, 0.4, 0.5, 0.6};
  ControlPipeline pipeline(HyqModel(), Gains(ControllerKind::kTwoStageId), {}, {}, kDt);
  Controller ctl(HyqModel(), Gains(ControllerKind::kTwoStageId));
  IdOutput a, b;
  EXPECT_EQ(pipeline.Compute(*c.dyn, c.in.q, c.in.v, c.tau_measured, c.ref.stance, kAll, c.ref,
                             ceiling, &a),
            ctl.Compute(*c.dyn, c.in.q, c.in.v, c.ref, ceiling, kDt, &b));
  EXPECT_EQ(a.tau_Nm, b.tau_Nm);
  EXPECT_EQ(pipeline.environment().mu, ceiling.mu);
  EXPECT_EQ(pipeline.disturbance().wrench(), dynamics::Vector6d::Zero());
}

TEST(ControlPipeline, NoHeapAfterWarmup) {
  HYQ_REQUIRE_HEAP_HOOKS();
  std::mt19937_64 rng(11);
  const Cycle a = MakeCycle(&rng, kAll), b = MakeCycle(&rng, kLfRh);
  ContactEnvironment ceiling;
  for (ControllerKind kind : {ControllerKind::kTwoStageId, ControllerKind::kNoSlipId,
                              ControllerKind::kPdGravity}) {
    ControlPipeline pipeline(HyqModel(), Gains(kind), FrictionOn(), ObserverOn(), kDt);
    IdOutput out;
    (void)pipeline.Compute(*a.dyn, a.in.q, a.in.v, a.tau_measured, a.ref.stance, kAll, a.ref,
                           ceiling, &out);
    (void)pipeline.Compute(*b.dyn, b.in.q, b.in.v, b.tau_measured, b.ref.stance, kAll, b.ref,
                           ceiling, &out);
    testing::NoHeapGuard guard;
    for (int k = 0; k < 20; ++k) {
      const Cycle& c = k % 2 ? a : b;
      (void)pipeline.Compute(*c.dyn, c.in.q, c.in.v, c.tau_measured, c.ref.stance, kAll, c.ref,
                             ceiling, &out);
      pipeline.HoldEnvironment(ceiling);
    }
    pipeline.Reset();
    EXPECT_EQ(guard.allocations(), 0u) << ToString(kind);
  }
}

}  // namespace
}  // namespace hyq::servo
