// What the servo thread hands to the telemetry thread: one TelemetrySnapshot per cycle (and
// SafetyEvents as they happen), through the TelemetrySink interface. The snapshot is made of the
// LCM messages themselves (lcmtypes/, package hyq_lcm): their generated C++ types are aggregates
// of scalars and fixed arrays, so the servo thread fills them in place (ServoLoop::FillSnapshot)
// and the copy onto the ring is one flat copy, with no allocation and no mapping to keep in step
// with the messages. Their fields are listed once, for every text form, in
// lcmtypes/telemetry_fields.h.
#pragma once

#include <cstdint>
#include <type_traits>

#include "hyq_lcm/lcmt_hyq_base_state.hpp"
#include "hyq_lcm/lcmt_hyq_contact_state.hpp"
#include "hyq_lcm/lcmt_hyq_disturbance_estimate.hpp"
#include "hyq_lcm/lcmt_hyq_friction_estimate.hpp"
#include "hyq_lcm/lcmt_hyq_health.hpp"
#include "hyq_lcm/lcmt_hyq_joint_state.hpp"
#include "hyq_lcm/lcmt_hyq_joint_torque.hpp"
#include "hyq_lcm/lcmt_hyq_servo_timing.hpp"
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

/// Everything the telemetry publishes about one cycle: one message per periodic channel. Each
/// message's utime and cycle are stamped from time_ns and cycle when it is published; the
/// health message's telemetry counters (snapshots_dropped .. commands_replayed) are the
/// telemetry thread's own and filled there too.
struct TelemetrySnapshot {
  std::uint64_t cycle = 0;
  std::int64_t time_ns = 0;  // cycle start (monotonic or virtual)
  hyq_lcm::lcmt_hyq_joint_state joint_state{};
  hyq_lcm::lcmt_hyq_joint_torque joint_torque{};
  hyq_lcm::lcmt_hyq_base_state base_state{};
  hyq_lcm::lcmt_hyq_contact_state contact{};
  hyq_lcm::lcmt_hyq_friction_estimate friction{};
  hyq_lcm::lcmt_hyq_disturbance_estimate disturbance{};
  hyq_lcm::lcmt_hyq_servo_timing timing{};
  hyq_lcm::lcmt_hyq_health health{};
};
static_assert(std::is_trivially_copyable_v<TelemetrySnapshot>,
              "the servo thread copies snapshots onto a ring: no member may allocate");

// the messages' fixed arrays hold what the servo's capacities say
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_joint_state::q_rad)> == kNumJoints);
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_contact_state::mu)> == kNumFeet);
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_friction_estimate::mu_estimate)> == kNumFeet);
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_health::buses)> == kMaxBuses);
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_health::device_state)> == kMaxDevices);
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_health::held_inputs)> == kMaxDevices);
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_health::max_held_in_row)> == kMaxDevices);

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
