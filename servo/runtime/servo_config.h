// The servo daemon's configuration: one struct per module, each declared by its module and
// filled from YAML by config/ (house style §1; config/servo_config_loader.h and
// config/hyq_servo.yaml, the default file). This struct only gathers them with the loop's own
// settings.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "hal/config_key.h"
#include "hal/hal_config.h"
#include "servo/common/servo_types.h"
#include "servo/command/command_config.h"
#include "servo/control/controller.h"
#include "servo/estimation/disturbance_observer.h"
#include "servo/estimation/foot_force_observer.h"
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
  // loaded from hal_file; hal.timing.cycle_period_s is the loop's period (the one place it is
  // stored: loop.rate_hz sets it, rate_hz() and period_s() read it)
  hal::HalConfig hal;
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
  // (hal timing.max_held_cycles) holds the input. In periods, so that another rate keeps it a
  // valid fraction of the period.
  double answer_wait_periods = 0.3;
  // lock-step: the bring-up's bound in wall time (the HAL's bringup_timeout_s counts simulated
  // time there, which stands still while nobody answers)
  double lockstep_bringup_timeout_s = 30.0;
  ControllerConfig controller;
  std::array<double, kNumFeet> mu{0.6, 0.6, 0.6, 0.6};  // the upper bound with the estimator on
  FrictionEstimatorConfig friction;     // contact.friction_estimation
  DisturbanceObserverConfig disturbance;  // controller.disturbance_observer
  FootForceObserverConfig foot_force;     // contact.foot_force_observer
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
  double sit_damping_light_fraction = 0.1;  // of it on a leg whose foot carries nothing
  // ... lasts until every joint has been slower than this for 0.2 s (the robot rests on the
  // ground: torque off before that would drop it), at least safety.damping_duration_s
  double sit_settle_speed_rad_s = 0.05;
  double sit_damping_max_s = 5.0;       // ... and at most this long
  double duration_s = 0.0;              // ACTIVE time after which the daemon stops; 0 = never
  // scripted steering of the trot (hyq-servod --steer; not a configuration key: an experiment's)
  std::array<TimedVelocity, kMaxTimedVelocities> steer{};
  std::size_t steer_count = 0;
  RealtimeConfig realtime;
  DeadlineConfig deadline;
  SafetyLimits safety;
  EstimatorConfig estimator;
  TelemetryConfig telemetry;
  CommandChannelConfig commands;

  double period_s() const noexcept { return hal.timing.cycle_period_s; }
  double rate_hz() const noexcept { return 1.0 / hal.timing.cycle_period_s; }
  double answer_wait_s() const noexcept { return answer_wait_periods / rate_hz(); }

  /// The file's keys (config/hyq_servo.yaml): the sections, and in them each module's own list.
  template <class A>
  void Serialize(A* a) {
    a->Section("robot", [this](auto* s) {
      s->Visit(hal::Key("urdf", &urdf).Required().Path().Doc("the robot's URDF"));
      s->Visit(hal::Key("hal", &hal_file).Required().Path()
                   .Doc("the HAL file: buses, devices, calibration (its keys: below)"));
    }, true);
    a->Include(hal_file, &hal);
    a->Period(&hal.timing.cycle_period_s);
    a->Visit(hal::Key("buses", &hal.buses).ByName()
                 .Doc("bus name: interface, replacing the HAL file's (e.g. lf: socketcan:can4)"));
    a->Section("loop", [this](auto* s) {
      s->Visit(hal::Key("rate_hz", &hal.timing.cycle_period_s).Reciprocal().In(50.0, 10000.0)
                   .Unit("Hz").Doc("the SYNC rate; absent: 1 / the HAL file's timing.cycle_period_s"));
      s->Visit(hal::Key("clock", &clock)
                   .Choices({{"realtime", ClockMode::kRealtime}, {"lockstep", ClockMode::kLockstep}})
                   .Doc("lockstep: hardware-in-the-loop with hyq-sim (virtual time)"));
      s->Visit(hal::Key("duration_s", &duration_s).In(0.0, 1e7).Unit("s")
                   .Doc("stop after this long in ACTIVE; 0: run until SIGINT / SIGTERM"));
      s->Visit(hal::Key("lockstep_timeout_s", &lockstep_timeout_s).In(1e-3, 60.0).Unit("s")
                   .Doc("lock-step: longest wait (wall clock) for the answers to a SYNC"));
      s->Visit(hal::Key("lockstep_short_timeout_s", &lockstep_short_timeout_s).In(1e-4, 60.0)
                   .Unit("s").Doc("... for 1000 cycles after an answer went missing"));
      s->Visit(hal::Key("lockstep_bringup_timeout_s", &lockstep_bringup_timeout_s).In(0.1, 3600.0)
                   .Unit("s").Doc("lock-step: the bring-up's bound in wall time"));
      s->Visit(hal::Key("answer_wait_periods", &answer_wait_periods).In(0.0, 0.5)
                   .Unit("periods").Doc("real time: a cycle's read waits this long for answers still owed"));
    });
    a->Section("controller", [this](auto* s) {
      controller.Serialize(s);
      s->Visit("disturbance_observer", &disturbance);
    });
    a->Section("contact", [this](auto* s) {
      s->Visit(hal::Key("mu", &mu).In(0.0, 2.0).Broadcast().Elements("(lf, rf, lh, rh)")
                   .Doc("the friction coefficient the controller assumes (the estimator's upper bound)"));
      s->Visit("friction_estimation", &friction);
      s->Visit("foot_force_observer", &foot_force);
    });
    a->Section("reference", [this](auto* s) {
      s->Visit(hal::Key("kind", &reference)
                   .Choices({{"stand", Reference::Kind::kStand},
                             {"trot", Reference::Kind::kTrot},
                             {"figure_eight", Reference::Kind::kFigureEight}})
                   .Doc("the motion once ACTIVE"));
      s->Visit(hal::Key("enable_ramp_s", &enable_ramp_s).In(0.0, 10.0).Unit("s")
                   .Doc("from the measured posture to the reference after enable"));
      s->Visit("trot", &trot);
      s->Visit("figure_eight", &figure_eight);
    });
    a->Section("operation", [this](auto* s) {
      s->Visit(hal::Key("auto_enable", &auto_enable).Doc("STANDBY → ACTIVE without an operator command"));
      s->Visit(hal::Key("stand_up_s", &stand_up_s).In(0.0, 30.0).Unit("s")
                   .Doc("after enable: from the resting crouch to standing height (0: off)"));
      s->Visit(hal::Key("sit_down_s", &sit_down_s).In(0.0, 30.0).Unit("s")
                   .Doc("a controlled stop or disable: down to the crouch first (0: damp at once)"));
      s->Visit(hal::Key("crouch_height_m", &crouch_height_m).In(0.34, 0.6).Unit("m")
                   .Doc("base height of that crouch"));
      s->Visit(hal::Key("sit_damping_Nms_per_rad", &sit_damping_Nms_per_rad).In(0.0, kMaxKdTau)
                   .Unit("N·m·s/rad").Doc("then damping, the legs folding under the trunk ..."));
      s->Visit(hal::Key("sit_damping_light_fraction", &sit_damping_light_fraction).In(0.0, 1.0)
                   .Doc("... that much of it on a leg whose foot carries nothing (the feet's force observer) ..."));
      s->Visit(hal::Key("sit_settle_speed_rad_s", &sit_settle_speed_rad_s).In(0.001, 1.0)
                   .Unit("rad/s").Doc("... until every joint is slower than this for 0.2 s ..."));
      s->Visit(hal::Key("sit_damping_max_s", &sit_damping_max_s).In(0.0, 60.0).Unit("s")
                   .Doc("... at least safety.damping_duration_s, at most this; then 0 N·m"));
    });
    a->Visit("realtime", &realtime);
    a->Visit("deadline", &deadline);
    a->Visit("safety", &safety);
    a->Visit("estimator", &estimator);
    a->Visit("telemetry", &telemetry);
    a->Visit("commands", &commands);
  }
};

}  // namespace hyq::servo
