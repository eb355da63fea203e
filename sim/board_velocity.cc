#include "sim/board_velocity.h"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace hyq::sim {

BoardVelocity::BoardVelocity(std::span<const hal::JointCalibration> joints, double sample_period_s,
                             double cutoff_hz)
    : period_s_(sample_period_s),
      alpha_(cutoff_hz > 0 ? -std::expm1(-2.0 * std::numbers::pi * cutoff_hz * sample_period_s)
                           : 1.0) {
  if (joints.size() != static_cast<std::size_t>(dynamics::kNumJoints))
    throw std::invalid_argument("board velocity: expected the 12 joints' calibrations, found " +
                                std::to_string(joints.size()));
  if (!(sample_period_s > 0))
    throw std::invalid_argument("board velocity: expected a sample period > 0 s, found " +
                                std::to_string(sample_period_s));
  if (!(cutoff_hz >= 0) || !std::isfinite(cutoff_hz))
    throw std::invalid_argument("board velocity: expected a filter cut-off >= 0 Hz, found " +
                                std::to_string(cutoff_hz));
  for (std::size_t j = 0; j < joints_.size(); ++j) joints_[j] = joints[j];
}

void BoardVelocity::Reset(const dynamics::VectorJ& q_rad) noexcept {
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const auto i = static_cast<std::size_t>(j);
    last_counts_[i] = hal::RadToEncoderCounts(joints_[i], q_rad(j));
    filtered_counts_s_[i] = 0.0;
  }
  velocity_rad_s_.setZero();
}

void BoardVelocity::Step(const dynamics::VectorJ& q_rad) noexcept {
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const auto i = static_cast<std::size_t>(j);
    const hal::EncoderCalibration& e = joints_[i].encoder;
    // ṽ = (c[k] − c[k−1]) / T  (1), in counts/s
    const std::int32_t c = hal::RadToEncoderCounts(joints_[i], q_rad(j));
    const double raw = static_cast<double>(static_cast<std::int64_t>(c) - last_counts_[i]) / period_s_;
    last_counts_[i] = c;
    // v += α (ṽ − v)  (2); without the filter, ṽ itself
    double& v = filtered_counts_s_[i];
    v = alpha_ == 1.0 ? raw : v + alpha_ * (raw - v);
    velocity_rad_s_(j) = e.direction * 2.0 * std::numbers::pi * v / e.counts_per_rev;
  }
}

}  // namespace hyq::sim
