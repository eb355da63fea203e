// What the servo thread hands to the telemetry thread: one TelemetrySnapshot per cycle (and
// SafetyEvents as they happen), through the TelemetrySink interface. Plain fixed-size values,
// turned into LCM messages (servo/telemetry/lcm_mapping.h) only on the telemetry thread.
#pragma once

#include <array>
#include <cstdint>

#include "servo/common/servo_types.h"

namespace hyq::servo {

/// Timings of one cycle, ns (stages in order).
struct CycleTiming {
  std::int64_t wakeup_latency_ns = 0;  // actual wake-up − scheduled wake-up
  std::int64_t read_ns = 0;            // HAL read (drain RX, decode, working counter)
  std::int64_t estimate_ns = 0;
  std::int64_t reference_ns = 0;
  std::int64_t control_ns = 0;         // dynamics + controller
  std::int64_t safety_ns = 0;
  std::int64_t write_ns = 0;           // HAL write (RPDOs + SYNC)
  std::int64_t total_ns = 0;           // read start .. write end
};

struct BusHealth {
  std::uint64_t rx_frames = 0, tx_frames = 0;
  std::uint64_t wkc_faults = 0, missing = 0, malformed = 0, error_frames = 0, emcy = 0;
  std::uint64_t bus_off = 0, tx_failed = 0, driver_dropped = 0;
  std::uint32_t wkc_expected = 0, wkc_received = 0;
};

/// Everything the telemetry publishes about one cycle.
struct TelemetrySnapshot {
  std::uint64_t cycle = 0;
  std::int64_t time_ns = 0;             // cycle start (monotonic or virtual)
  double reference_time_s = 0.0;        // time along the reference (0 until ACTIVE)
  ServoMode mode = ServoMode::kInit;
  ControllerKind controller = ControllerKind::kPid;

  // joints
  std::array<double, kNumJoints> q_rad{}, qd_rad_s{}, tau_measured_Nm{};
  std::array<double, kNumJoints> q_ref_rad{}, qd_ref_rad_s{}, tau_command_Nm{};
  std::array<std::uint8_t, kNumJoints> input_status{};  // hal::InputStatus

  // estimated base state (world frame; orientation as quaternion w, x, y, z)
  std::array<double, 3> base_position_m{}, base_velocity_m_s{}, base_angular_velocity_rad_s{};
  std::array<double, 4> base_orientation_wxyz{1.0, 0.0, 0.0, 0.0};

  // contacts and the inverse dynamics
  std::array<std::uint8_t, kNumFeet> stance_reference{}, stance_estimated{};
  std::array<double, kNumFeet> mu{};
  std::array<std::array<double, 3>, kNumFeet> contact_force_N{};  // impulse / dt, world
  std::uint8_t stage1_status = 0, stage2_status = 0, fallback = 0;  // qp::Status, servo::Fallback
  std::int32_t stage1_iterations = 0, stage2_iterations = 0;
  double stage1_solve_us = 0.0, stage2_solve_us = 0.0;
  double tracking_error_rad = 0.0;      // ‖q_ref − q‖

  // friction estimation (servo/estimation/friction_estimator.h)
  bool friction_enabled = false;
  std::array<double, kNumFeet> mu_estimate{}, mu_upper{}, mu_confidence{}, force_ratio{};
  std::array<double, kNumFeet> slip_speed_m_s{};
  std::array<std::array<double, 3>, kNumFeet> foot_force_N{};     // from the load cells, world
  std::array<std::uint8_t, kNumFeet> foot_loaded{}, foot_slipping{};
  std::array<std::uint32_t, kNumFeet> slips{}, footfalls{};

  // the trunk's disturbance observer (servo/estimation/disturbance_observer.h)
  bool disturbance_enabled = false, disturbance_held = true;
  std::array<double, 3> disturbance_force_N{};     // world
  std::array<double, 3> disturbance_torque_Nm{};   // base frame

  // timing and deadline
  CycleTiming timing;
  std::uint64_t deadline_misses = 0;    // cycles whose work overran the budget
  std::uint32_t consecutive_misses = 0;
  std::uint64_t skipped_cycles = 0;     // periods skipped to get back on schedule

  // device and bus health
  std::uint8_t num_buses = 0;
  std::array<BusHealth, kMaxBuses> buses{};
  std::uint8_t num_devices = 0;
  std::array<std::uint8_t, kMaxDevices> device_state{};  // hal::DeviceState
  std::array<std::uint64_t, kMaxDevices> held_inputs{};  // cycles a device's input was held
  std::array<std::uint32_t, kMaxDevices> max_held_in_row{};
  std::uint32_t max_held_cycles = 0;                     // the hold limit (HAL timing)
  std::uint8_t hal_read_status = 0, hal_write_status = 0;     // hal::HalStatus
  std::uint64_t events = 0;             // safety events so far
};

/// Where snapshots and events go and commands come from (the LCM telemetry thread's rings, or a
/// test double). Every call is made from the servo thread and must be wait-free.
class TelemetrySink {
 public:
  virtual ~TelemetrySink() = default;
  virtual bool Push(const TelemetrySnapshot& s) noexcept = 0;
  virtual bool PushEvent(const SafetyEvent& e) noexcept = 0;
  virtual bool PopCommand(ServoCommand* c) noexcept = 0;
};

}  // namespace hyq::servo
