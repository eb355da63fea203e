#include "hal/calibration.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "hal/config_error.h"

namespace hyq::hal {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

std::int32_t SaturatingRound(double x) noexcept {
  if (!(x == x)) return 0;  // NaN
  constexpr double kMax = 2147483647.0, kMin = -2147483648.0;
  return static_cast<std::int32_t>(std::lround(std::clamp(x, kMin, kMax)));
}

}  // namespace

double CylinderLength(const CylinderGeometry& g, double q_rad) noexcept {
  // L = sqrt(a^2 + b^2 - 2ab cos phi)  (2)
  const double phi = g.phi0_rad + g.phi_per_q * q_rad;
  return std::sqrt(g.a_m * g.a_m + g.b_m * g.b_m - 2.0 * g.a_m * g.b_m * std::cos(phi));
}

double LeverArm(const CylinderGeometry& g, double q_rad) noexcept {
  // r = dL/dq = s a b sin(phi) / L  (3)
  const double phi = g.phi0_rad + g.phi_per_q * q_rad;
  const double length = CylinderLength(g, q_rad);
  if (!(length > 0.0)) return 0.0;
  return g.phi_per_q * g.a_m * g.b_m * std::sin(phi) / length;
}

double EncoderCountsToRad(const JointCalibration& c, std::int32_t counts) noexcept {
  const double delta = static_cast<double>(counts) - static_cast<double>(c.encoder.offset_counts);
  return c.encoder.direction * kTwoPi * delta / c.encoder.counts_per_rev;
}

std::int32_t RadToEncoderCounts(const JointCalibration& c, double q_rad) noexcept {
  return SaturatingRound(static_cast<double>(c.encoder.offset_counts) +
                         c.encoder.direction * q_rad * c.encoder.counts_per_rev / kTwoPi);
}

double EncoderRateToRadPerSec(const JointCalibration& c, std::int32_t counts_per_s) noexcept {
  return c.encoder.direction * kTwoPi * static_cast<double>(counts_per_s) /
         c.encoder.counts_per_rev;
}

std::int32_t RadPerSecToEncoderRate(const JointCalibration& c, double qd_rad_s) noexcept {
  return SaturatingRound(c.encoder.direction * qd_rad_s * c.encoder.counts_per_rev / kTwoPi);
}

double EffortCountsToSensorValue(const JointCalibration& c, std::int32_t counts) noexcept {
  return c.effort.gain *
         (static_cast<double>(counts) - static_cast<double>(c.effort.offset_counts));
}

std::int32_t SensorValueToEffortCounts(const JointCalibration& c, double value) noexcept {
  return SaturatingRound(static_cast<double>(c.effort.offset_counts) + value / c.effort.gain);
}

double EffortCountsToTorque(const JointCalibration& c, std::int32_t counts,
                            double q_rad) noexcept {
  const double sensed = EffortCountsToSensorValue(c, counts);
  if (c.kind == ActuatorKind::kRotary) return sensed;  // (1)
  return sensed * LeverArm(c.cylinder, q_rad);         // tau = F r(q)  (3)
}

std::int32_t TorqueToEffortCounts(const JointCalibration& c, double tau_Nm,
                                  double q_rad) noexcept {
  if (c.kind == ActuatorKind::kRotary) return SensorValueToEffortCounts(c, tau_Nm);
  const double r = LeverArm(c.cylinder, q_rad);
  if (r == 0.0) return c.effort.offset_counts;
  return SensorValueToEffortCounts(c, tau_Nm / r);
}

void ValidateCalibration(const JointCalibration& c, std::string_view joint_name) {
  const std::string who = "calibration of " + std::string(joint_name) + ": ";
  if (!(c.encoder.counts_per_rev > 0.0))
    throw ConfigError(who + "encoder.counts_per_rev must be > 0, found " +
                      std::to_string(c.encoder.counts_per_rev));
  if (c.encoder.direction != 1 && c.encoder.direction != -1)
    throw ConfigError(who + "encoder.direction must be +1 or -1, found " +
                      std::to_string(c.encoder.direction));
  if (!(c.effort.gain != 0.0) || !std::isfinite(c.effort.gain))
    throw ConfigError(who + "effort gain must be finite and non-zero, found " +
                      std::to_string(c.effort.gain));
  if (!(c.q_min_rad < c.q_max_rad))
    throw ConfigError(who + "joint range must satisfy q_min < q_max, found [" +
                      std::to_string(c.q_min_rad) + ", " + std::to_string(c.q_max_rad) + "]");
  if (!(c.torque_limit_Nm > 0.0))
    throw ConfigError(who + "torque_limit_Nm must be > 0, found " +
                      std::to_string(c.torque_limit_Nm));
  if (c.kind != ActuatorKind::kCylinder) return;
  const CylinderGeometry& g = c.cylinder;
  if (!(g.a_m > 0.0) || !(g.b_m > 0.0))
    throw ConfigError(who + "cylinder a_m and b_m must be > 0, found a_m = " +
                      std::to_string(g.a_m) + ", b_m = " + std::to_string(g.b_m));
  if (g.phi_per_q != 1.0 && g.phi_per_q != -1.0)
    throw ConfigError(who + "cylinder.phi_per_q must be +1 or -1, found " +
                      std::to_string(g.phi_per_q));
  // the lever arm must keep one sign and stay away from zero over the whole joint range
  constexpr int kSamples = 200;
  constexpr double kMinLeverArm_m = 1e-3;
  const double r0 = LeverArm(g, c.q_min_rad);
  for (int i = 0; i <= kSamples; ++i) {
    const double q = c.q_min_rad + (c.q_max_rad - c.q_min_rad) * i / kSamples;
    const double r = LeverArm(g, q);
    if (std::abs(r) < kMinLeverArm_m || (r > 0.0) != (r0 > 0.0))
      throw ConfigError(who + "cylinder lever arm r(q) must keep one sign with |r| >= 1 mm over "
                        "[q_min, q_max]; found r(" + std::to_string(q) + " rad) = " +
                        std::to_string(r) + " m (check phi0_rad, a_m, b_m)");
  }
}

}  // namespace hyq::hal
