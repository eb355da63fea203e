// The servo daemon's configuration (house style §1: servo declares it, config/ fills it from
// YAML, see config/servo_config_loader.h and config/hyq_servo.yaml, the default file).
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "hal/hal_config.h"
#include "servo/controller.h"
#include "servo/reference.h"

namespace hyq::servo {

/// How the loop keeps time.
enum class ClockMode : std::uint8_t {
  kRealtime,  // wake on CLOCK_MONOTONIC absolute time, one period apart
  kLockstep,  // virtual time: after each SYNC wait for the answers, then run the next cycle at
              // once (hardware-in-the-loop with a simulator stepping once per SYNC)
};
const char* ToString(ClockMode m) noexcept;

struct RealtimeSettings {
  bool enabled = true;            // try SCHED_FIFO, affinity and mlockall (warn when refused)
  int priority = 80;              // SCHED_FIFO priority of the servo thread, 1..99
  int cpu = -1;                   // pin the servo thread to this CPU; −1: do not pin
  bool lock_memory = true;        // mlockall(MCL_CURRENT | MCL_FUTURE)
  std::uint32_t prefault_stack_kib = 256;  // stack touched before the first cycle
};

struct DeadlineSettings {
  double budget_fraction = 0.9;   // cycle work (read .. write) must end within this × period
  int max_consecutive_misses = 5; // this many misses in a row → DAMPING (reason kDeadlineMiss)
};

struct SafetyLimits {
  double position_margin_rad = 0.15;    // allowed beyond the joint range before it is a fault
  double max_velocity_rad_s = 15.0;     // |q̇| above this is implausible
  double max_position_jump_rad = 0.1;   // |q_k − q_{k−1}| above this in one cycle is a fault
  double max_measured_torque_Nm = 600.0;  // |τ_measured| above this is implausible
  double max_gyro_rad_s = 20.0;
  double max_accel_m_s2 = 200.0;
  int max_missing_cycles = 2;           // an input missing this many cycles in a row → fault
  double max_tilt_rad = 1.2;            // estimated roll or pitch beyond this → fault
  double damping_Nms_per_rad = 30.0;    // DAMPING: τ = −D q̇
  double damping_duration_s = 1.0;      // then zero torque (FAULT or STOPPED)
  bool damp_on_bad_command = true;      // a refused command while ACTIVE → DAMPING
};

struct EstimatorSettings {
  double stance_force_N = 60.0;         // a scheduled-stance foot carries at least this
  double tilt_correction_gain = 0.5;    // 1/s, accelerometer tilt correction (complementary)
  double velocity_blend = 0.1;          // per cycle: weight of the kinematic velocity vs IMU
  double imu_gravity_window_m_s2 = 1.5; // use the accelerometer for tilt when |a| ≈ g ± this
};

struct TelemetrySettings {
  bool enabled = true;
  std::string lcm_url = "udpm://239.255.76.67:7667?ttl=0";
  std::string channel_prefix = "HYQ_";
  int state_decimation = 1;             // joint state, torques, contacts: every Nth cycle
  int timing_decimation = 10;
  int health_decimation = 100;
};

struct CommandSettings {
  bool enabled = false;                 // the command channel exists only when enabled
  std::string channel = "HYQ_COMMAND";
  double max_rate_hz = 20.0;
};

struct ServoConfig {
  std::string source;                   // the file it came from
  std::string urdf;                     // resolved path
  std::string hal_file;                 // resolved path
  hal::HalConfig hal;                   // loaded from hal_file; timing.cycle_period_s = 1 / rate
  double rate_hz = 1000.0;
  ClockMode clock = ClockMode::kRealtime;
  double lockstep_timeout_s = 0.2;        // lock-step: longest wait for the devices' answers
  double lockstep_short_timeout_s = 0.002;  // ... for 1000 cycles after an answer was missing
  ControllerConfig controller;
  std::array<double, kNumFeet> mu{0.6, 0.6, 0.6, 0.6};
  Reference::Kind reference = Reference::Kind::kStand;
  TrotParams trot;
  FigureEightParams figure_eight;
  double enable_ramp_s = 0.5;           // blend from the measured posture to the reference
  bool auto_enable = false;             // STANDBY → ACTIVE without an operator command
  double duration_s = 0.0;              // ACTIVE time after which the daemon stops; 0 = never
  RealtimeSettings realtime;
  DeadlineSettings deadline;
  SafetyLimits safety;
  EstimatorSettings estimator;
  TelemetrySettings telemetry;
  CommandSettings command;

  double period_s() const noexcept { return 1.0 / rate_hz; }
};

}  // namespace hyq::servo
