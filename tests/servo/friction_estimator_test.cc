// The per-foot friction estimator (servo/estimation/friction_estimator.h) on synthetic forces and
// foot velocities: sticking raises the bound, a slip sets the value, footfalls start from the
// place's estimate or the prior, the commanded μ bounds it, untrusted slip evidence holds it, no
// heap in the cycle.
#include "servo/estimation/friction_estimator.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "tests/support/no_heap_guard.h"

namespace hyq::servo {
namespace {

constexpr double kDt = 1e-3;

FrictionEstimatorConfig Config() {
  FrictionEstimatorConfig c;
  c.enabled = true;
  c.prior_mu = 1.0;
  c.min_mu = 0.05;
  c.margin = 0.2;
  c.min_normal_N = 40.0;
  c.slip_speed_m_s = 0.04;
  c.slip_cycles = 3;
  c.slip_alignment = 0.7;
  c.touchdown_blank_s = 0.0;  // the blanking has a test of its own
  c.stick_speed_m_s = 0.015;
  c.rise_per_s = 0.5;
  c.slip_filter = 0.2;
  c.memory_radius_m = 0.15;
  return c;
}

// foot 0 loaded with f_n = 400 N and |f_t| = ratio f_n along +x, its contact point moving at
// `speed` along −x (friction opposes the slip), at x; the other feet in swing
std::array<FootFrictionInput, kNumFeet> Foot0(double ratio, double speed, double x = 0.0,
                                              bool stance = true, double fn = 400.0) {
  std::array<FootFrictionInput, kNumFeet> in{};
  in[0].stance = stance;
  in[0].force_W = Eigen::Vector3d(ratio * fn, 0.0, fn);
  in[0].velocity_W = Eigen::Vector3d(-speed, 0.0, 0.0);
  in[0].position_W = Eigen::Vector3d(x, 0.2, 0.0);
  return in;
}

constexpr std::array<double, kNumFeet> kUpper{1.0, 1.0, 1.0, 1.0};
constexpr std::array<bool, kNumFeet> kTrusted{true, true, true, true};
constexpr std::array<bool, kNumFeet> kFoot0Untrusted{false, true, true, true};

void Step(FrictionEstimator& e, const std::array<FootFrictionInput, kNumFeet>& in, int cycles,
         const std::array<double, kNumFeet>& upper = kUpper,
         const std::array<bool, kNumFeet>& evidence_ok = kTrusted) {
  for (int i = 0; i < cycles; ++i) e.Update(in, evidence_ok, upper, kDt);
}

TEST(FrictionEstimator, AFootfallStartsFromThePrior) {
  FrictionEstimator e(Config());
  Step(e, Foot0(0.05, 0.0), 1);
  EXPECT_TRUE(e.foot(0).loaded);
  EXPECT_EQ(e.foot(0).footfalls, 1u);
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 1.0);
  EXPECT_DOUBLE_EQ(e.foot(0).confidence, 0.0);
  EXPECT_DOUBLE_EQ(e.foot(0).mu_control, 0.8);  // (1 − margin) μ̂
  EXPECT_NEAR(e.foot(0).ratio, 0.05, 1e-12);
  EXPECT_FALSE(e.foot(1).loaded);
}

TEST(FrictionEstimator, ASlipSetsTheValueAfterTheConfiguredCycles) {
  FrictionEstimator e(Config());
  Step(e, Foot0(0.3, 0.0), 10);  // sticking on the prior
  Step(e, Foot0(0.12, 0.2), 2);  // two cycles of slip speed: not yet a slip
  EXPECT_FALSE(e.foot(0).slipping);
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 1.0);
  Step(e, Foot0(0.12, 0.2), 1);  // the third: ρ at slip is μ
  EXPECT_TRUE(e.foot(0).slipping);
  EXPECT_NEAR(e.foot(0).mu, 0.12, 1e-12);
  EXPECT_DOUBLE_EQ(e.foot(0).confidence, 1.0);
  EXPECT_EQ(e.foot(0).slips, 1u);
  EXPECT_NEAR(e.foot(0).mu_control, 0.8 * 0.12, 1e-12);
  // while the slip lasts, further ρ are filtered in
  Step(e, Foot0(0.10, 0.2), 1);
  EXPECT_NEAR(e.foot(0).mu, 0.12 + 0.2 * (0.10 - 0.12), 1e-12);
  EXPECT_EQ(e.foot(0).slips, 1u);
}

TEST(FrictionEstimator, StickingRaisesTheBoundAndProbesTowardsThePrior) {
  FrictionEstimator e(Config());
  Step(e, Foot0(0.1, 0.2), 3);  // slip: μ̂ = 0.1
  ASSERT_NEAR(e.foot(0).mu, 0.1, 1e-12);
  // sticking at ρ = 0.3 proves μ ≥ 0.3 at once, then the estimate rises 0.5/s
  Step(e, Foot0(0.3, 0.0), 1);
  EXPECT_NEAR(e.foot(0).lower_bound, 0.3, 1e-12);
  EXPECT_NEAR(e.foot(0).mu, 0.3 + 0.5 * kDt, 1e-12);
  EXPECT_FALSE(e.foot(0).slipping);
  Step(e, Foot0(0.3, 0.0), 999);
  EXPECT_NEAR(e.foot(0).mu, 0.3 + 0.5, 1e-9);  // 1000 cycles at 0.5/s
  EXPECT_LT(e.foot(0).confidence, 0.2);          // a guess above what was seen
  Step(e, Foot0(0.3, 0.0), 2000);
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 1.0);           // never above the prior
  EXPECT_EQ(e.foot(0).slips, 1u);
}

TEST(FrictionEstimator, AMotionTheForceDoesNotOpposeIsNoSlip) {
  FrictionEstimator e(Config());
  auto in = Foot0(0.1, 0.2);
  in[0].velocity_W = Eigen::Vector3d(0.0, 0.2, 0.0);  // across f_t: not Coulomb sliding
  Step(e, in, 20);
  EXPECT_FALSE(e.foot(0).slipping);
  EXPECT_EQ(e.foot(0).slips, 0u);
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 1.0);
  in[0].velocity_W = Eigen::Vector3d(0.2, 0.0, 0.0);  // along f_t
  Step(e, in, 20);
  EXPECT_EQ(e.foot(0).slips, 0u);
  Step(e, Foot0(0.1, 0.2), 3);                        // against f_t: a slip
  EXPECT_EQ(e.foot(0).slips, 1u);
}

TEST(FrictionEstimator, TheImpactOfAFootfallProvesNothing) {
  FrictionEstimatorConfig c = Config();
  c.touchdown_blank_s = 0.03;
  FrictionEstimator e(c);
  Step(e, Foot0(0.3, 0.5), 29);  // sliding-like for 29 ms after the footfall
  EXPECT_FALSE(e.foot(0).slipping);
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 1.0);
  Step(e, Foot0(0.3, 0.5), 3);   // from 30 ms on it counts
  EXPECT_TRUE(e.foot(0).slipping);
  EXPECT_NEAR(e.foot(0).mu, 0.3, 1e-12);
  // lift-off and a new footfall: the blanking starts again
  Step(e, Foot0(0.0, 0.0, 0.0, false), 5);
  Step(e, Foot0(0.05, 0.5, 3.0), 10);
  EXPECT_FALSE(e.foot(0).slipping);
  EXPECT_EQ(e.foot(0).slips, 1u);
}

// The state estimator does not vouch for the base velocity foot 0's slip velocity is measured
// against: an apparent slip does not lower μ̂, a stick does not raise it, and each held cycle is
// counted; with the evidence trusted the same inputs do.
TEST(FrictionEstimator, UntrustedEvidenceNeitherLowersNorRaisesTheEstimate) {
  FrictionEstimator e(Config());
  Step(e, Foot0(0.12, 0.2), 50, kUpper, kFoot0Untrusted);  // slip speed, opposed: looks like a slip
  EXPECT_FALSE(e.foot(0).slipping);
  EXPECT_TRUE(e.foot(0).evidence_held);
  EXPECT_EQ(e.foot(0).held_cycles, 50u);
  EXPECT_EQ(e.foot(0).slips, 0u);
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 1.0);
  EXPECT_DOUBLE_EQ(e.foot(0).mu_control, 0.8);
  EXPECT_NEAR(e.foot(0).ratio, 0.12, 1e-12);  // still measured and published
  EXPECT_FALSE(e.foot(1).evidence_held);      // an unloaded foot holds nothing
  // trusted: the same inputs are a slip after slip_cycles in a row (the held cycles did not count)
  Step(e, Foot0(0.12, 0.2), 2);
  EXPECT_FALSE(e.foot(0).slipping);
  EXPECT_FALSE(e.foot(0).evidence_held);
  Step(e, Foot0(0.12, 0.2), 1);
  EXPECT_TRUE(e.foot(0).slipping);
  EXPECT_NEAR(e.foot(0).mu, 0.12, 1e-12);
  EXPECT_EQ(e.foot(0).slips, 1u);
  EXPECT_EQ(e.foot(0).held_cycles, 50u);
  // sticking at ρ = 0.3 while untrusted: no bound, no rise towards the prior, confidence kept
  Step(e, Foot0(0.3, 0.0), 100, kUpper, kFoot0Untrusted);
  EXPECT_NEAR(e.foot(0).mu, 0.12, 1e-12);
  EXPECT_DOUBLE_EQ(e.foot(0).lower_bound, 0.0);
  EXPECT_DOUBLE_EQ(e.foot(0).confidence, 1.0);
  EXPECT_EQ(e.foot(0).held_cycles, 150u);
  Step(e, Foot0(0.3, 0.0), 1);  // trusted: the bound at once, then the rise
  EXPECT_NEAR(e.foot(0).mu, 0.3 + 0.5 * kDt, 1e-12);
}

// A slip run interrupted by an untrusted cycle starts again: slip_cycles trusted cycles in a row
TEST(FrictionEstimator, AnUntrustedCycleRestartsTheSlipCount) {
  FrictionEstimator e(Config());
  Step(e, Foot0(0.3, 0.0), 10);
  Step(e, Foot0(0.12, 0.2), 2);
  Step(e, Foot0(0.12, 0.2), 1, kUpper, kFoot0Untrusted);
  Step(e, Foot0(0.12, 0.2), 2);
  EXPECT_FALSE(e.foot(0).slipping);
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 1.0);
  Step(e, Foot0(0.12, 0.2), 1);
  EXPECT_TRUE(e.foot(0).slipping);
  EXPECT_EQ(e.foot(0).slips, 1u);
  // the evidence lost during a slip: the slip ends there, its return is a new slip at the new ρ
  Step(e, Foot0(0.10, 0.2), 1, kUpper, kFoot0Untrusted);
  EXPECT_FALSE(e.foot(0).slipping);
  EXPECT_NEAR(e.foot(0).mu, 0.12, 1e-12);
  Step(e, Foot0(0.10, 0.2), 3);
  EXPECT_EQ(e.foot(0).slips, 2u);
  EXPECT_NEAR(e.foot(0).mu, 0.10, 1e-12);
}

TEST(FrictionEstimator, BetweenStickAndSlipSpeedsTheEstimateHolds) {
  FrictionEstimator e(Config());
  Step(e, Foot0(0.2, 0.2), 3);
  ASSERT_NEAR(e.foot(0).mu, 0.2, 1e-12);
  Step(e, Foot0(0.25, 0.03), 500);  // 3 cm/s: neither sticking (1.5) nor slipping (4)
  EXPECT_NEAR(e.foot(0).mu, 0.2, 1e-12);
}

TEST(FrictionEstimator, AnUnloadedFootProvesNothing) {
  FrictionEstimator e(Config());
  Step(e, Foot0(0.1, 0.5, 0.0, true, 20.0), 50);  // 20 N < min_normal_N
  EXPECT_FALSE(e.foot(0).loaded);
  EXPECT_EQ(e.foot(0).slips, 0u);
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 1.0);
  Step(e, Foot0(0.1, 0.5, 0.0, false), 50);  // in swing
  EXPECT_FALSE(e.foot(0).loaded);
  EXPECT_EQ(e.foot(0).footfalls, 0u);
}

TEST(FrictionEstimator, TheCommandedMuIsAnUpperBound) {
  FrictionEstimator e(Config());
  const std::array<double, kNumFeet> upper{0.4, 0.4, 0.4, 0.4};
  Step(e, Foot0(0.05, 0.0), 100, upper);
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 0.4);  // the prior, capped
  EXPECT_NEAR(e.foot(0).mu_control, 0.32, 1e-12);
  Step(e, Foot0(0.6, 0.0), 100, upper);   // sticking beyond the bound does not lift it
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 0.4);
  EXPECT_LE(e.foot(0).mu_control, 0.4);
  // a measured slip below the floor stays at the floor
  Step(e, Foot0(0.01, 0.3), 3, upper);
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 0.05);
  EXPECT_DOUBLE_EQ(e.foot(0).mu_control, 0.05);
}

TEST(FrictionEstimator, AFootfallStartsFromTheEstimateRememberedAtThatPlace) {
  FrictionEstimator e(Config());
  Step(e, Foot0(0.1, 0.2, 1.0), 3);           // slips at x = 1.0: μ̂ = 0.1
  Step(e, Foot0(0.0, 0.0, 1.0, false), 10);   // lift-off: remembered at x = 1.0
  Step(e, Foot0(0.05, 0.0, 1.1), 1);          // 0.1 m away: starts there
  EXPECT_EQ(e.foot(0).footfalls, 2u);
  EXPECT_NEAR(e.foot(0).mu, 0.1 + 0.5 * kDt, 1e-12);  // and sticks, so it rises
  EXPECT_DOUBLE_EQ(e.foot(0).confidence, 1.0 * std::exp(-kDt / 0.5));
  Step(e, Foot0(0.0, 0.0, 1.1, false), 10);
  Step(e, Foot0(0.05, 0.0, 3.0), 1);          // 2 m away: the prior
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 1.0);
  e.Reset();
  Step(e, Foot0(0.05, 0.0, 1.0), 1);          // Reset forgets the places
  EXPECT_DOUBLE_EQ(e.foot(0).mu, 1.0);
}

TEST(FrictionEstimator, NonFiniteInputsAreTreatedAsUnloaded) {
  FrictionEstimator e(Config());
  auto in = Foot0(0.1, 0.3);
  in[0].force_W.x() = std::numeric_limits<double>::quiet_NaN();
  Step(e, in, 10);
  EXPECT_FALSE(e.foot(0).loaded);
  EXPECT_TRUE(std::isfinite(e.foot(0).mu));
  EXPECT_TRUE(std::isfinite(e.foot(0).mu_control));
  EXPECT_TRUE(e.foot(0).force_W.allFinite());
}

TEST(FrictionEstimator, NoHeapInTheCycle) {
  if (!testing::NoHeapGuard::Available()) GTEST_SKIP() << "allocator hooks compiled out (sanitizer build)";
  FrictionEstimator e(Config());
  Step(e, Foot0(0.3, 0.0), 1);
  testing::NoHeapGuard guard;
  for (int k = 0; k < 200; ++k) {
    const double x = 0.01 * k;
    Step(e, Foot0(k % 3 ? 0.1 : 0.3, k % 50 < 10 ? 0.3 : 0.0, x, k % 40 < 30), 1, kUpper,
         k % 7 ? kTrusted : kFoot0Untrusted);
  }
  EXPECT_EQ(guard.allocations(), 0u);
}

}  // namespace
}  // namespace hyq::servo
