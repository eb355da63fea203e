// The joint velocity an actuator board reports: not the plant's exact velocity, but what the
// board computes from its own encoder every sample, as HyQ's boards have no velocity sensor
// (docs/simulation.md, "Sensors"):
//
//   c[k]  = c0 + round(d q[k] N / 2π)                 the encoder's counts (hal/calibration.h)
//   ṽ[k]  = (c[k] − c[k−1]) / T                       backward difference, counts/s        (1)
//   v[k]  = v[k−1] + α (ṽ[k] − v[k−1]),               first-order low-pass                 (2)
//   α     = 1 − exp(−2π f_c T)                        (f_c = 0: no filter, v = ṽ)
//
// with T the board's sample period (the plant step) and q[k] the angle the encoder sees (noise
// included). Together
//   H(z) = α (1 − z⁻¹) / (T (1 − (1 − α) z⁻¹))                                           (3)
// from the angle to the velocity. (1) resolves one count per sample, 2π/(N T) = 47.9 mrad/s for
// N = 131072 and T = 1 ms, and is the mean velocity over the last sample: T/2 late. (2) lets
// through α/(2 − α) of the variance of (1)'s quantisation noise and adds (1 − α)/α · T of lag
// at low frequency: after a velocity step the reading rises as 1 − (1 − α)^k. With f_c =
// 250 Hz = 1/(4T) (kBoardVelocityCutoffHz): α = 0.792, 0.26 ms more lag (0.76 ms in all), the
// noise's σ × 0.81. The filter and its f_c are this project's choice for a HyQ-class board, not
// HyQ's documented one; docs/simulation.md gives the reasons and what each f_c costs.
//
// Step() allocates nothing and never throws.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "dynamics/model.h"
#include "hal/calibration.h"

namespace hyq::sim {

/// The boards' low-pass, f_c of (2): a quarter of the 1 kHz sample rate (docs/simulation.md).
inline constexpr double kBoardVelocityCutoffHz = 250.0;

class BoardVelocity {
 public:
  /// joints: the 12 joints' calibrations (the encoders' counts per revolution, offset and
  /// direction); sample_period_s: T; cutoff_hz: f_c (0: no filter). Throws std::invalid_argument
  /// at configuration time (12 calibrations, T > 0, f_c >= 0).
  BoardVelocity(std::span<const hal::JointCalibration> joints, double sample_period_s,
                double cutoff_hz);

  /// At rest at the angles q: the last counts those of q, the velocity 0.
  void Reset(const dynamics::VectorJ& q_rad) noexcept;
  /// One board sample of the angles the encoders see: (1), then (2).
  void Step(const dynamics::VectorJ& q_rad) noexcept;
  /// v[k] in rad/s at the joint (the encoder's direction applied).
  const dynamics::VectorJ& velocity_rad_s() const noexcept { return velocity_rad_s_; }
  double alpha() const noexcept { return alpha_; }

 private:
  std::array<hal::JointCalibration, dynamics::kNumJoints> joints_;
  double period_s_, alpha_;
  std::array<std::int32_t, dynamics::kNumJoints> last_counts_{};
  std::array<double, dynamics::kNumJoints> filtered_counts_s_{};
  dynamics::VectorJ velocity_rad_s_ = dynamics::VectorJ::Zero();
};

}  // namespace hyq::sim
