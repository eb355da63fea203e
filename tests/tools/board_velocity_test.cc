// The boards' joint velocity (sim/board_velocity.h) against its own equations computed here
// independently: a ramp reads its rate after the first-order rise of (2), a sine comes out with
// the gain and phase of the transfer function (3), the default encoder's reading is quantised to
// one count per sample and averages to the true rate (label sim).
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/no_heap_guard.h"
#include "sim/board_velocity.h"

namespace hyq::sim {
namespace {

constexpr double kT = 0.001;  // the board's sample period, s

// 12 joints on encoders of n counts per revolution, every other one counting against the joint
std::vector<hal::JointCalibration> Joints(double counts_per_rev) {
  std::vector<hal::JointCalibration> j(dynamics::kNumJoints);
  for (std::size_t i = 0; i < j.size(); ++i) {
    j[i].encoder.counts_per_rev = counts_per_rev;
    j[i].encoder.offset_counts = static_cast<std::int32_t>(1000 * i);
    j[i].encoder.direction = i % 2 == 0 ? 1 : -1;
  }
  return j;
}

// an encoder so fine (2^30 counts) that its quantisation is below 1e-5 rad/s of velocity
constexpr double kFine = 1073741824.0;

TEST(BoardVelocity, ARampReadsItsRateAfterTheFirstOrderRise) {
  for (double fc : {0.0, 50.0, kBoardVelocityCutoffHz}) {
    BoardVelocity b(Joints(kFine), kT, fc);
    const double alpha = fc > 0 ? 1 - std::exp(-2 * std::numbers::pi * fc * kT) : 1.0;
    EXPECT_NEAR(b.alpha(), alpha, 1e-15);
    const dynamics::VectorJ q0 = dynamics::VectorJ::LinSpaced(-1.0, 1.0);
    const dynamics::VectorJ w = dynamics::VectorJ::LinSpaced(-3.0, 2.5);  // rad/s
    b.Reset(q0);
    EXPECT_EQ(b.velocity_rad_s(), dynamics::VectorJ::Zero());
    for (int k = 1; k <= 40; ++k) {
      b.Step(q0 + w * (k * kT));
      // ṽ = ω from the first sample on; (2) rises as 1 − (1 − α)^k
      const double rise = 1 - std::pow(1 - alpha, k);
      for (int j = 0; j < dynamics::kNumJoints; ++j)
        ASSERT_NEAR(b.velocity_rad_s()(j), w(j) * rise, 2e-5) << "f_c " << fc << " k " << k << " j " << j;
    }
  }
}

// (3) at the sine's frequency: H(e^{iωT}) = α (1 − e^{−iωT}) / (T (1 − (1 − α) e^{−iωT}))
TEST(BoardVelocity, ASineComesOutWithTheTransferFunctionsGainAndPhase) {
  const double fc = kBoardVelocityCutoffHz, f = 25.0, amp = 0.3;
  const double wt = 2 * std::numbers::pi * f;
  BoardVelocity b(Joints(kFine), kT, fc);
  const double alpha = b.alpha();
  const std::complex<double> z1 = std::exp(std::complex<double>(0, -wt * kT));
  const std::complex<double> H = alpha * (1.0 - z1) / (kT * (1.0 - (1.0 - alpha) * z1));
  b.Reset(dynamics::VectorJ::Zero());
  for (int k = 1; k <= 400; ++k) {
    const double t = k * kT;
    b.Step(dynamics::VectorJ::Constant(amp * std::sin(wt * t)));
    if (k < 100) continue;  // the start's transient: (1 − α)^100 is nothing
    // the steady response to sin: |H| sin(ωt + arg H)
    const double expected = amp * std::abs(H) * std::sin(wt * t + std::arg(H));
    for (int j = 0; j < dynamics::kNumJoints; ++j)
      ASSERT_NEAR(b.velocity_rad_s()(j), expected, 2e-5) << "k " << k << " j " << j;
  }
  // what that is: the velocity's amplitude a little below ωA, late by about T/2 + (1 − α)/α T
  EXPECT_NEAR(std::abs(H) / wt, 1.0, 0.02);
  const double lag_s = -(std::arg(H) - std::numbers::pi / 2) / wt;
  EXPECT_NEAR(lag_s, 0.5 * kT + (1 - alpha) / alpha * kT, 0.05e-3);
}

TEST(BoardVelocity, TheDefaultEncoderResolvesOneCountPerSampleAndAveragesToTheRate) {
  const double n = 131072.0, count_rate = 2 * std::numbers::pi / n / kT;  // 47.9 mrad/s
  BoardVelocity raw(Joints(n), kT, 0.0), filtered(Joints(n), kT, kBoardVelocityCutoffHz);
  const double w = 0.123456;  // rad/s: 2.58 counts per sample, never whole
  raw.Reset(dynamics::VectorJ::Zero());
  filtered.Reset(dynamics::VectorJ::Zero());
  double sum = 0, sum2 = 0, fsum2 = 0;
  const int steps = 2000;
  for (int k = 1; k <= steps; ++k) {
    const dynamics::VectorJ q = dynamics::VectorJ::Constant(w * k * kT);
    raw.Step(q);
    filtered.Step(q);
    for (int j = 0; j < dynamics::kNumJoints; ++j) {
      // (1) is a whole number of counts per sample, within one count of the rate
      const double counts = raw.velocity_rad_s()(j) / count_rate;
      ASSERT_NEAR(counts, std::round(counts), 1e-9) << k;
      ASSERT_LE(std::abs(raw.velocity_rad_s()(j) - w), count_rate + 1e-12) << k;
    }
    sum += raw.velocity_rad_s()(0);
    sum2 += std::pow(raw.velocity_rad_s()(0) - w, 2);
    if (k > 50) fsum2 += std::pow(filtered.velocity_rad_s()(0) - w, 2);
  }
  // the counts telescope: the mean is the rate within one count over the run
  EXPECT_NEAR(sum / steps, w, count_rate / steps + 1e-12);
  // the filter takes out part of the quantisation noise (a periodic one here, not white: only
  // the order of α/(2 − α) is checked)
  const double rms = std::sqrt(sum2 / steps), frms = std::sqrt(fsum2 / (steps - 50));
  EXPECT_GT(rms, 0.3 * count_rate);
  EXPECT_LT(frms, rms);
}

TEST(BoardVelocity, RefusesABadConfiguration) {
  EXPECT_THROW(BoardVelocity(Joints(131072.0), 0.0, 200.0), std::invalid_argument);
  EXPECT_THROW(BoardVelocity(Joints(131072.0), kT, -1.0), std::invalid_argument);
  EXPECT_THROW(BoardVelocity(std::vector<hal::JointCalibration>(3), kT, 200.0), std::invalid_argument);
  try {
    BoardVelocity(Joints(131072.0), kT, -1.0);
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("cut-off >= 0 Hz, found -1"), std::string::npos) << e.what();
  }
}

TEST(BoardVelocity, StepDoesNotAllocate) {
  HYQ_REQUIRE_HEAP_HOOKS();
  BoardVelocity b(Joints(131072.0), kT, 200.0);
  b.Reset(dynamics::VectorJ::Zero());
  dynamics::VectorJ q = dynamics::VectorJ::Zero();
  testing::NoHeapGuard guard;
  for (int k = 0; k < 100; ++k) {
    q.array() += 1e-3;
    b.Step(q);
  }
  EXPECT_EQ(guard.allocations(), 0u);
}

}  // namespace
}  // namespace hyq::sim
