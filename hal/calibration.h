// Joint calibration: encoder counts -> joint angle and velocity, effort-sensor counts -> joint
// torque, and the inverse mappings the device emulator uses.
//
// HAA joints are rotary hydraulic actuators with a torque sensor:
//   tau = g (c - c0)                                                        (1)
// HFE and KFE joints are driven by linear cylinders with a load cell. The cylinder's two
// attachment points sit at distances a and b from the joint axis and enclose the angle
// phi(q) = phi0 + s q (s = +-1) at the joint, so by the law of cosines the cylinder length is
//   L(q) = sqrt(a^2 + b^2 - 2 a b cos phi(q))                               (2)
// and by virtual work (F dL = tau dq) the joint torque of a cylinder force F (N, + = pushing) is
//   tau = F r(q),   r(q) = dL/dq = s a b sin phi(q) / L(q)                  (3)
// Encoders:  q = d 2 pi (c - c0) / N,  qd = d 2 pi cd / N   (d = +-1, N counts per revolution).
#pragma once

#include <cstdint>
#include <numbers>
#include <optional>
#include <string_view>

#include "hal/config_key.h"

namespace hyq::hal {

enum class ActuatorKind : std::uint8_t { kRotary, kCylinder };

/// The configuration files give angles in degrees; the calibration stores radians.
inline constexpr double kRadPerDeg = std::numbers::pi / 180.0;

/// The check of a sign key (Key::Check): +1 or -1.
template <class T>
std::optional<Violation> PlusOrMinusOne(const T& s) {
  if (s == 1 || s == -1) return std::nullopt;
  return Violation{"+1 or -1"};
}

struct EncoderCalibration {
  double counts_per_rev = 131072.0;  // joint-side counts per joint revolution
  std::int32_t offset_counts = 0;    // counts at q = 0
  int direction = 1;                 // +1 or -1: sign between counts and q

  template <class A>
  void Serialize(A* a) {
    a->Visit(Key("counts_per_rev", &counts_per_rev).Required().Unit("counts")
                 .Check([](const double& n) -> std::optional<Violation> {
                   if (n > 0.0) return std::nullopt;
                   return Violation{"a number > 0"};
                 })
                 .Doc("joint-side counts per joint revolution"));
    a->Visit(Key("offset_counts", &offset_counts).Required().Unit("counts").Doc("counts at q = 0"));
    a->Visit(Key("direction", &direction).Required().In(-1, 1).Check(PlusOrMinusOne<int>)
                 .Doc("+1 or -1: the sign between counts and q"));
  }
};

/// Effort sensor: load cell (N per count) on cylinders, torque sensor (N·m per count) on HAA.
struct EffortSensorCalibration {
  double gain = 0.01;
  std::int32_t offset_counts = 0;
};

/// The cylinder triangle of eq. (2)-(3).
struct CylinderGeometry {
  double a_m = 0.05;
  double b_m = 0.30;
  double phi0_rad = 1.5708;
  double phi_per_q = 1.0;  // s in eq. (2): +1 or -1

  template <class A>
  void Serialize(A* a) {
    a->Visit(Key("a_m", &a_m).Required().Unit("m").Doc("cylinders: one attachment point's distance from the joint axis"));
    a->Visit(Key("b_m", &b_m).Required().Unit("m").Doc("cylinders: the other attachment point's distance from the axis"));
    a->Visit(Key("phi0_deg", &phi0_rad).Required().Scale(kRadPerDeg).Unit("deg")
                 .Doc("cylinders: the angle phi between the two at q = 0 (hal/calibration.h)"));
    a->Visit(Key("phi_per_q", &phi_per_q).Required()
                 .Check(PlusOrMinusOne<double>)
                 .Doc("cylinders: s in phi = phi0 + s q, +1 or -1"));
  }
};

struct JointCalibration {
  ActuatorKind kind = ActuatorKind::kRotary;
  EncoderCalibration encoder;
  EffortSensorCalibration effort;
  CylinderGeometry cylinder;  // used when kind == kCylinder
  double torque_limit_Nm = 150.0;
  double q_min_rad = -3.0;
  double q_max_rad = 3.0;

  /// The keys of `joints.<name>`: the sensor and the cylinder geometry depend on `actuator`.
  template <class A>
  void Serialize(A* a) {
    a->Visit(Key("actuator", &kind).Required().Selects()
                 .Choices({{"rotary", ActuatorKind::kRotary}, {"cylinder", ActuatorKind::kCylinder}})
                 .Doc("rotary (HAA, torque sensor) or cylinder (HFE, KFE, load cell)"));
    a->Section("encoder", [this](auto* e) { encoder.Serialize(e); }, true);
    const bool rotary = kind == ActuatorKind::kRotary;
    a->Section(rotary ? "torque_sensor" : "load_cell", [this, rotary](auto* s) {
      s->Visit(Key(rotary ? "gain_Nm_per_count" : "gain_N_per_count", &effort.gain).Required()
                   .Unit(rotary ? "N·m/count" : "N/count")
                   .Check([](const double& g) -> std::optional<Violation> {
                     if (g != 0.0) return std::nullopt;
                     return Violation{"a non-zero gain"};
                   })
                   .Doc(rotary ? "rotary: N·m per count, tau = gain (counts - offset)" : "cylinders: N per count, F = gain (counts - offset)"));
      s->Visit(Key("offset_counts", &effort.offset_counts).Required().Unit("counts")
                   .Doc("sensor counts at zero effort"));
    }, true);
    if (!rotary) a->Section("cylinder", [this](auto* g) { cylinder.Serialize(g); }, true);
    MemberList<2> range{&q_min_rad, &q_max_rad};
    a->Visit(Key("range_deg", &range).Required().Scale(kRadPerDeg).Elements("(min, max)").Unit("deg")
                 .Check([](const MemberList<2>& r) -> std::optional<Violation> {
                   if (*r[0] < *r[1]) return std::nullopt;
                   return Violation{"min < max"};
                 })
                 .Doc("the joint's range"));
    a->Visit(Key("torque_limit_Nm", &torque_limit_Nm).Required().Unit("N·m")
                 .Doc("the HAL clamps the commanded torque to ± this"));
  }
};

/// L(q), eq. (2), in m.
double CylinderLength(const CylinderGeometry& g, double q_rad) noexcept;
/// r(q) = dL/dq, eq. (3), in m (signed).
double LeverArm(const CylinderGeometry& g, double q_rad) noexcept;

double EncoderCountsToRad(const JointCalibration& c, std::int32_t counts) noexcept;
std::int32_t RadToEncoderCounts(const JointCalibration& c, double q_rad) noexcept;
double EncoderRateToRadPerSec(const JointCalibration& c, std::int32_t counts_per_s) noexcept;
std::int32_t RadPerSecToEncoderRate(const JointCalibration& c, double qd_rad_s) noexcept;

/// Cylinder force in N (kCylinder) or HAA torque in N·m (kRotary) from sensor counts.
double EffortCountsToSensorValue(const JointCalibration& c, std::int32_t counts) noexcept;
std::int32_t SensorValueToEffortCounts(const JointCalibration& c, double value) noexcept;

/// Joint torque in N·m from the effort-sensor counts at joint angle q, eq. (1) or (3).
double EffortCountsToTorque(const JointCalibration& c, std::int32_t counts, double q_rad) noexcept;
/// Inverse of EffortCountsToTorque (for the emulator): the counts a sensor reports for tau at q.
std::int32_t TorqueToEffortCounts(const JointCalibration& c, double tau_Nm, double q_rad) noexcept;

/// Throws ConfigError naming `joint_name` when the calibration is unusable: counts_per_rev <= 0,
/// direction not +-1, zero gain, non-positive a or b, |s| != 1, q range empty, or a lever arm
/// that vanishes or changes sign inside [q_min, q_max] (the torque would be unobservable).
void ValidateCalibration(const JointCalibration& c, std::string_view joint_name);

}  // namespace hyq::hal
