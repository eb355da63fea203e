// The safety layer's limits (docs/servo.md, "Safety"): what the input and output checks accept
// and how the safe states behave. Filled from the `safety` section of the daemon's YAML.
#pragma once

namespace hyq::servo {

struct SafetyLimits {
  double position_margin_rad = 0.15;    // allowed beyond the joint range before it is a fault
  double max_velocity_rad_s = 15.0;     // |q̇| above this is implausible
  double max_position_jump_rad = 0.1;   // |q_k − q_{k−1}| above this in one cycle is a fault
  double max_measured_torque_Nm = 600.0;  // |τ_measured| above this is implausible
  double max_gyro_rad_s = 20.0;
  double max_accel_m_s2 = 200.0;
  double max_tilt_rad = 1.2;            // estimated roll or pitch beyond this → fault
  double damping_Nms_per_rad = 30.0;    // DAMPING: τ = −D q̇
  double damping_duration_s = 1.0;      // then zero torque (FAULT or STOPPED)
  bool damp_on_bad_command = true;      // a refused command while ACTIVE → DAMPING
};

}  // namespace hyq::servo
