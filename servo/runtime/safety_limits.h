// The safety layer's limits (docs/servo.md, "Safety"): what the input and output checks accept
// and how the safe states behave. Filled from the `safety` section of the daemon's YAML.
#pragma once

#include "hal/config_key.h"
#include "servo/common/servo_types.h"

namespace hyq::servo {

struct SafetyLimits {
  double position_margin_rad = 0.15;    // allowed beyond the joint range before it is a fault
  double max_velocity_rad_s = 15.0;     // |q̇| above this is implausible
  double max_position_jump_rad = 0.1;   // |q_k − q_{k−1}| above this in one cycle is a fault
  double max_measured_torque_Nm = 600.0;  // |τ_measured| above this is implausible
  double max_gyro_rad_s = 20.0;
  double max_accel_m_s2 = 200.0;
  double max_tilt_rad = 1.2;            // estimated roll or pitch beyond this → fault
  double damping_Nms_per_rad = 100.0;   // DAMPING (a cut, a damp command): τ = −D q̇
  double damping_duration_s = 1.0;      // then zero torque (FAULT or STOPPED)
  bool damp_on_bad_command = true;      // a refused command while ACTIVE → DAMPING

  template <class A>
  void Serialize(A* a) {
    // the safety layer's own tolerance for missing inputs would be a second policy beside the
    // HAL's; the key is refused so that an old file does not believe it still applies
    a->Visit(hal::RetiredKey{"max_missing_cycles",
                             "no such key: a late or missing input is held for up to "
                             "timing.max_held_cycles of the HAL file (robot.hal) and the next one "
                             "is a fault; set it there",
                             "the key, which the safety layer no longer has"});
    a->Visit(hal::Key("position_margin_rad", &position_margin_rad).In(0.0, 1.0).Unit("rad")
                 .Doc("allowed beyond the joint range before it is a fault"));
    a->Visit(hal::Key("max_velocity_rad_s", &max_velocity_rad_s).In(0.1, 100.0).Unit("rad/s")
                 .Doc("|q̇| above this is implausible"));
    a->Visit(hal::Key("max_position_jump_rad", &max_position_jump_rad).In(1e-4, 1.0).Unit("rad")
                 .Doc("|q_k − q_{k−1}| above this in one cycle is a fault"));
    a->Visit(hal::Key("max_measured_torque_Nm", &max_measured_torque_Nm).In(1.0, 1e5).Unit("N·m")
                 .Doc("|τ_measured| above this is implausible"));
    a->Visit(hal::Key("max_gyro_rad_s", &max_gyro_rad_s).In(0.1, 100.0).Unit("rad/s")
                 .Doc("IMU rate above this is implausible"));
    a->Visit(hal::Key("max_accel_m_s2", &max_accel_m_s2).In(1.0, 1e4).Unit("m/s²")
                 .Doc("IMU acceleration above this is implausible"));
    a->Visit(hal::Key("max_tilt_rad", &max_tilt_rad).In(0.05, 3.2).Unit("rad")
                 .Doc("estimated roll or pitch beyond this is a fault"));
    a->Visit(hal::Key("damping_Nms_per_rad", &damping_Nms_per_rad).In(0.0, kMaxKdTau)
                 .Unit("N·m·s/rad").Doc("DAMPING (a cut, a damp command): τ = −D q̇"));
    a->Visit(hal::Key("damping_duration_s", &damping_duration_s).In(0.0, 60.0).Unit("s")
                 .Doc("then zero torque (FAULT or STOPPED)"));
    a->Visit(hal::Key("damp_on_bad_command", &damp_on_bad_command)
                 .Doc("a refused command while ACTIVE → DAMPING"));
  }
};

}  // namespace hyq::servo
