// The feet's force observer (servo/estimation/foot_force_observer.h) against independent
// references: HyQ standing still on four feet with known ground forces (the least-norm forces
// that hold its weight; the observer finds each through K/(s + K) exactly), the robot in the air
// with its legs driven hard (the motion integrated here from the model's forward dynamics: no
// ground force at all, while the joint torques alone, a massless leg's reading, say hundreds of
// newtons), the contact probability's logistic, a non-finite input and no heap in the cycle.
#include "servo/estimation/foot_force_observer.h"

#include <cmath>
#include <limits>
#include <memory>

#include <gtest/gtest.h>

#include "dynamics/configuration.h"
#include "dynamics/kinematics.h"
#include "tests/dynamics/hyq_fixture.h"
#include "tests/dynamics/rk4.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::servo {
namespace {

using dynamics::CycleDynamics;
using dynamics::VectorJ;
using dynamics::VectorQ;
using dynamics::VectorV;
using testing::HyqModel;

constexpr double kDt = 1e-3;

FootForceObserverConfig Config() { return FootForceObserverConfig{}; }

std::unique_ptr<CycleDynamics> Dynamics(const VectorQ& q, const VectorV& v) {
  auto d = std::make_unique<CycleDynamics>();
  EXPECT_EQ(dynamics::ComputeCycleDynamics(HyqModel(), q, v, d.get()), dynamics::DynamicsStatus::kOk);
  return d;
}

dynamics::FootJacobian ContactJacobian(const CycleDynamics& d, int f) {
  dynamics::FootJacobian J;
  Eigen::Vector3d unused;
  dynamics::ContactPointJacobian(HyqModel(), d.feet, f, Eigen::Vector3d::UnitZ(), &J, &unused);
  return J;
}

TEST(FootForceObserver, TheGroundForcesOfAStandingRobotAreFoundThroughItsPole) {
  VectorQ q = HyqModel().StandingQ();
  const auto d = Dynamics(q, VectorV::Zero());
  // the least-norm ground forces that hold the trunk: Σ J_f,bᵀ f_f = h_b
  Eigen::Matrix<double, 6, 12> A;
  for (int f = 0; f < 4; ++f) A.middleCols<3>(3 * f) = ContactJacobian(*d, f).leftCols<6>().transpose();
  const Eigen::Matrix<double, 12, 1> forces = A.transpose() * (A * A.transpose()).ldlt().solve(d->bias.head<6>());
  VectorV tau_ext = VectorV::Zero();
  for (int f = 0; f < 4; ++f) tau_ext += ContactJacobian(*d, f).transpose() * forces.segment<3>(3 * f);
  const VectorJ tau = (d->bias - tau_ext).tail<dynamics::kNumJoints>();  // at rest: M v̇ = 0
  FootForceObserver obs(HyqModel(), Config(), kDt);
  obs.Update(*d, VectorV::Zero(), tau);  // anchors the momentum
  const double K = 2.0 * M_PI * Config().bandwidth_hz;
  for (int k = 1; k <= 100; ++k) {
    obs.Update(*d, VectorV::Zero(), tau);
    const double s = 1.0 - std::exp(-K * k * kDt);
    for (int f = 0; f < 4; ++f)
      ASSERT_TRUE(obs.force_W()[static_cast<std::size_t>(f)].isApprox(s * forces.segment<3>(3 * f), 1e-9))
          << "foot " << f << " at cycle " << k;
  }
  for (int f = 0; f < 4; ++f) {
    EXPECT_GT(forces(3 * f + 2), 150.0);  // each foot carries a quarter of the weight or so
    EXPECT_GT(obs.probability()[static_cast<std::size_t>(f)], 0.999);
  }
}

// in the air under gravity, the legs driven by large sinusoidal torques about the standing
// posture: q(t), v(t) from M v̇ = Sᵀ τ − h (RK4, 10 steps per cycle); no foot touches anything
TEST(FootForceObserver, ALegPushingThroughTheAirIsNotLoaded) {
  const dynamics::Model& model = HyqModel();
  auto d = std::make_unique<CycleDynamics>();
  const auto torque = [&](const VectorQ& q, const VectorV& v, double t) {
    VectorJ tau;
    for (int j = 0; j < dynamics::kNumJoints; ++j)
      tau(j) = 300.0 * (model.q_standing(j) - q(dynamics::QIndexOfJoint(j))) -
               6.0 * v(dynamics::VIndexOfJoint(j)) + 80.0 * std::sin(2.0 * M_PI * 3.0 * t + j);
    return tau;
  };
  const auto vdot = [&](const VectorQ& q, const VectorV& v, double t) {
    EXPECT_EQ(dynamics::ComputeCycleDynamics(model, q, v, d.get()), dynamics::DynamicsStatus::kOk);
    VectorV f = -d->bias;
    f.tail<dynamics::kNumJoints>() += torque(q, v, t);
    return VectorV(d->M.ldlt().solve(f));
  };
  VectorQ q = model.StandingQ();
  VectorV v = VectorV::Zero();
  FootForceObserver obs(model, Config(), kDt);
  double worst_observed = 0.0, worst_massless = 0.0;
  constexpr int kSub = 10;
  const double h = kDt / kSub;
  for (int k = 0; k <= 300; ++k) {
    const double t = k * kDt;
    const VectorJ tau = torque(q, v, t);
    const auto dk = Dynamics(q, v);
    obs.Update(*dk, v, tau);
    for (int f = 0; f < 4; ++f) {
      const auto ff = static_cast<std::size_t>(f);
      // what the joint torques alone say (a massless leg: τ + J_legᵀ F = 0)
      const Eigen::Matrix3d J = ContactJacobian(*dk, f).middleCols<3>(6 + 3 * f);
      const Eigen::Vector3d massless = -J.transpose().partialPivLu().solve(tau.segment<3>(3 * f));
      if (k > 20) {
        worst_observed = std::max(worst_observed, obs.force_W()[ff].norm());
        worst_massless = std::max(worst_massless, massless.norm());
        ASSERT_LT(obs.probability()[ff], 0.01) << "foot " << f << " at cycle " << k;
      }
    }
    for (int i = 0; i < kSub; ++i) testing::Rk4Step(vdot, t + i * h, h, &q, &v);
  }
  std::printf("in the air: observed |F| <= %.2f N, the torques' massless-leg reading up to %.0f N\n",
              worst_observed, worst_massless);
  EXPECT_LT(worst_observed, 2.0);  // the trapezoid's and midpoint rule's error at 1 kHz
  EXPECT_GT(worst_massless, 2.0 * Config().force_N);  // loaded, by the torques alone
}

TEST(FootForceObserver, ANonFiniteInputHoldsTheEstimateAndTheCycleHasNoHeap) {
  HYQ_REQUIRE_HEAP_HOOKS();
  const VectorQ q = HyqModel().StandingQ();
  const auto d = Dynamics(q, VectorV::Zero());
  const VectorJ tau = d->bias.tail<dynamics::kNumJoints>() - VectorJ::Constant(5.0);
  FootForceObserver obs(HyqModel(), Config(), kDt);
  testing::NoHeapGuard guard;
  for (int k = 0; k < 50; ++k) obs.Update(*d, VectorV::Zero(), tau);
  const auto before = obs.force_W();
  VectorV bad = VectorV::Zero();
  bad(7) = std::numeric_limits<double>::quiet_NaN();
  obs.Update(*d, bad, tau);
  for (std::size_t f = 0; f < 4; ++f) EXPECT_EQ(obs.force_W()[f], before[f]);
  obs.Update(*d, VectorV::Zero(), tau);  // restarts at this cycle's momentum, r kept
  for (std::size_t f = 0; f < 4; ++f) EXPECT_TRUE(obs.force_W()[f].isApprox(before[f], 1e-12));
  obs.Reset();
  for (std::size_t f = 0; f < 4; ++f) EXPECT_EQ(obs.probability()[f], 0.0);
  EXPECT_EQ(guard.allocations(), 0u);
}

}  // namespace
}  // namespace hyq::servo
