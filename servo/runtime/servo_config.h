// The servo daemon's configuration: one struct per module, each declared by its module and
// filled from YAML by config/ (house style §1; config/servo_config_loader.h and
// config/hyq_servo.yaml, the default file). This struct only gathers them with the loop's own
// settings.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "hal/hal_config.h"
#include "servo/common/servo_types.h"
#include "servo/command/command_config.h"
#include "servo/control/controller.h"
#include "servo/estimation/disturbance_observer.h"
#include "servo/estimation/estimator.h"
#include "servo/estimation/friction_estimator.h"
#include "servo/reference/reference.h"
#include "servo/runtime/deadline_monitor.h"
#include "servo/runtime/realtime_thread.h"
#include "servo/runtime/safety_limits.h"
#include "servo/telemetry/telemetry_config.h"

namespace hyq::servo {

/// How the loop keeps time.
enum class ClockMode : std::uint8_t {
  kRealtime,  // wake on CLOCK_MONOTONIC absolute time, one period apart
  kLockstep,  // virtual time: after each SYNC wait for the answers, then run the next cycle at
              // once (hardware-in-the-loop with a simulator stepping once per SYNC)
};
const char* ToString(ClockMode m) noexcept;

struct ServoConfig {
  std::string source;                   // the file it came from
  std::string urdf;                     // resolved path
  std::string hal_file;                 // resolved path
  hal::HalConfig hal;                   // loaded from hal_file; timing.cycle_period_s = 1 / rate
  double rate_hz = 1000.0;
  ClockMode clock = ClockMode::kRealtime;
  // lock-step: longest wait (wall clock) for the devices' answers; generous, because in lock-step
  // a late answer costs nothing physical, and a busy machine can starve the simulator that long
  double lockstep_timeout_s = 2.0;
  double lockstep_short_timeout_s = 0.002;  // ... for 1000 cycles after an answer was missing
  // real time: how long after it began a cycle's read waits for the answers to the last SYNC
  // that have not arrived yet (as an EtherCAT master waits for its frame to return), so that a
  // SYNC that went out late, or answers delayed by a stall, still count; never past
  // (period − this) after the nominal start; 0: no wait.
  // Counted in the cycle's read time and deadline; beyond it the one late-or-missing policy
  // (hal timing.max_held_cycles) holds the input. The file gives it in periods
  // (loop.answer_wait_periods, default 0.3)
  double answer_wait_s = 300e-6;
  // lock-step: the bring-up's bound in wall time (the HAL's bringup_timeout_s counts simulated
  // time there, which stands still while nobody answers)
  double lockstep_bringup_timeout_s = 30.0;
  ControllerConfig controller;
  std::array<double, kNumFeet> mu{0.6, 0.6, 0.6, 0.6};  // the upper bound with the estimator on
  FrictionEstimatorConfig friction;     // contact.friction_estimation
  DisturbanceObserverConfig disturbance;  // controller.disturbance_observer
  Reference::Kind reference = Reference::Kind::kStand;
  TrotParams trot;
  FigureEightParams figure_eight;
  double enable_ramp_s = 0.5;           // blend from the measured posture to the reference
  bool auto_enable = false;             // STANDBY → ACTIVE without an operator command
  // stand up and sit down (servo/reference/posture.h): 0 s = off (the enable ramp from the
  // measured posture; a stop damps at once)
  double stand_up_s = 0.0;              // after enable: from the resting crouch to standing height
  double sit_down_s = 0.0;              // a controlled stop or disable: down to the crouch first
  double crouch_height_m = 0.36;        // base height of the crouch the robot sits down to
  double sit_damping_Nms_per_rad = 80.0;  // the damping after a sit-down (a fault's: safety.*)
  // ... lasts until every joint has been slower than this for 0.2 s (the robot rests on the
  // ground: torque off before that would drop it), at least safety.damping_duration_s
  double sit_settle_speed_rad_s = 0.05;
  double sit_damping_max_s = 5.0;       // ... and at most this long
  double duration_s = 0.0;              // ACTIVE time after which the daemon stops; 0 = never
  RealtimeConfig realtime;
  DeadlineConfig deadline;
  SafetyLimits safety;
  EstimatorConfig estimator;
  TelemetryConfig telemetry;
  CommandChannelConfig commands;

  double period_s() const noexcept { return 1.0 / rate_hz; }
};

}  // namespace hyq::servo
