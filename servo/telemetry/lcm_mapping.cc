#include "servo/telemetry/lcm_mapping.h"

#include <algorithm>
#include <cstring>
#include <type_traits>

namespace hyq::servo {
namespace {

// std::array -> the generated C array of the same length (element types may differ)
template <class T, std::size_t N, class U>
void CopyArray(const std::array<T, N>& from, U (*to)[N]) {
  for (std::size_t i = 0; i < N; ++i) (*to)[i] = static_cast<U>(from[i]);
}

// the messages' fixed arrays hold what the servo's capacities say
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_health::buses)> == kMaxBuses);
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_health::device_state)> == kMaxDevices);
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_health::held_inputs)> == kMaxDevices);
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_health::max_held_in_row)> == kMaxDevices);
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_joint_state::q_rad)> == kNumJoints);
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_contact_state::mu)> == kNumFeet);
static_assert(std::extent_v<decltype(hyq_lcm::lcmt_hyq_friction_estimate::mu_estimate)> == kNumFeet);

}  // namespace

void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_joint_state* out) noexcept {
  hyq_lcm::lcmt_hyq_joint_state& m = *out;
  m.utime = s.time_ns / 1000;
  m.cycle = static_cast<std::int64_t>(s.cycle);
  m.mode = static_cast<std::int8_t>(s.mode);
  m.reference_time_s = s.reference_time_s;
  CopyArray(s.q_rad, &m.q_rad);
  CopyArray(s.qd_rad_s, &m.qd_rad_s);
  CopyArray(s.tau_measured_Nm, &m.tau_measured_Nm);
  CopyArray(s.q_ref_rad, &m.q_ref_rad);
  CopyArray(s.qd_ref_rad_s, &m.qd_ref_rad_s);
  CopyArray(s.input_status, &m.input_status);
  m.tracking_error_rad = s.tracking_error_rad;
}

void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_joint_torque* out) noexcept {
  hyq_lcm::lcmt_hyq_joint_torque& m = *out;
  m.utime = s.time_ns / 1000;
  m.cycle = static_cast<std::int64_t>(s.cycle);
  m.mode = static_cast<std::int8_t>(s.mode);
  m.controller = static_cast<std::int8_t>(s.controller);
  CopyArray(s.tau_command_Nm, &m.tau_command_Nm);
}

void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_base_state* out) noexcept {
  hyq_lcm::lcmt_hyq_base_state& m = *out;
  m.utime = s.time_ns / 1000;
  m.cycle = static_cast<std::int64_t>(s.cycle);
  CopyArray(s.base_position_m, &m.position_m);
  CopyArray(s.base_orientation_wxyz, &m.orientation_wxyz);
  CopyArray(s.base_velocity_m_s, &m.velocity_m_s);
  CopyArray(s.base_angular_velocity_rad_s, &m.angular_velocity_rad_s);
}

void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_contact_state* out) noexcept {
  hyq_lcm::lcmt_hyq_contact_state& m = *out;
  m.utime = s.time_ns / 1000;
  m.cycle = static_cast<std::int64_t>(s.cycle);
  m.controller = static_cast<std::int8_t>(s.controller);
  for (int f = 0; f < kNumFeet; ++f) {
    m.stance_reference[f] = s.stance_reference[f] != 0;
    m.stance_estimated[f] = s.stance_estimated[f] != 0;
    m.mu[f] = s.mu[f];
    CopyArray(s.contact_force_N[f], &m.contact_force_N[f]);
  }
  m.stage1_status = static_cast<std::int8_t>(s.stage1_status);
  m.stage2_status = static_cast<std::int8_t>(s.stage2_status);
  m.fallback = static_cast<std::int8_t>(s.fallback);
  m.stage1_iterations = s.stage1_iterations;
  m.stage2_iterations = s.stage2_iterations;
  m.stage1_solve_us = s.stage1_solve_us;
  m.stage2_solve_us = s.stage2_solve_us;
}

void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_disturbance_estimate* out) noexcept {
  hyq_lcm::lcmt_hyq_disturbance_estimate& m = *out;
  m.utime = s.time_ns / 1000;
  m.cycle = static_cast<std::int64_t>(s.cycle);
  m.enabled = s.disturbance_enabled;
  m.held = s.disturbance_held;
  CopyArray(s.disturbance_force_N, &m.force_N);
  CopyArray(s.disturbance_torque_Nm, &m.torque_Nm);
  m.payload_kg = -s.disturbance_force_N[2] / 9.81;
}

void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_friction_estimate* out) noexcept {
  hyq_lcm::lcmt_hyq_friction_estimate& m = *out;
  m.utime = s.time_ns / 1000;
  m.cycle = static_cast<std::int64_t>(s.cycle);
  m.enabled = s.friction_enabled;
  CopyArray(s.mu_estimate, &m.mu_estimate);
  CopyArray(s.mu, &m.mu_control);
  CopyArray(s.mu_upper, &m.mu_upper);
  CopyArray(s.mu_confidence, &m.confidence);
  CopyArray(s.force_ratio, &m.force_ratio);
  CopyArray(s.slip_speed_m_s, &m.slip_speed_m_s);
  for (std::size_t f = 0; f < kNumFeet; ++f) {
    CopyArray(s.foot_force_N[f], &m.force_N[f]);
    m.loaded[f] = s.foot_loaded[f] != 0;
    m.slipping[f] = s.foot_slipping[f] != 0;
    m.slips[f] = static_cast<std::int32_t>(s.slips[f]);
    m.footfalls[f] = static_cast<std::int32_t>(s.footfalls[f]);
  }
}

void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_servo_timing* out) noexcept {
  hyq_lcm::lcmt_hyq_servo_timing& m = *out;
  m.utime = s.time_ns / 1000;
  m.cycle = static_cast<std::int64_t>(s.cycle);
  m.wakeup_latency_ns = s.timing.wakeup_latency_ns;
  m.read_ns = s.timing.read_ns;
  m.estimate_ns = s.timing.estimate_ns;
  m.reference_ns = s.timing.reference_ns;
  m.control_ns = s.timing.control_ns;
  m.safety_ns = s.timing.safety_ns;
  m.write_ns = s.timing.write_ns;
  m.total_ns = s.timing.total_ns;
  m.deadline_misses = static_cast<std::int64_t>(s.deadline_misses);
  m.consecutive_misses = static_cast<std::int32_t>(s.consecutive_misses);
  m.skipped_cycles = static_cast<std::int64_t>(s.skipped_cycles);
}

void ToLcm(const TelemetrySnapshot& s, const TelemetryStats& st, hyq_lcm::lcmt_hyq_health* msg) noexcept {
  hyq_lcm::lcmt_hyq_health& m = *msg;
  m.utime = s.time_ns / 1000;
  m.cycle = static_cast<std::int64_t>(s.cycle);
  m.mode = static_cast<std::int8_t>(s.mode);
  m.hal_read_status = static_cast<std::int8_t>(s.hal_read_status);
  m.hal_write_status = static_cast<std::int8_t>(s.hal_write_status);
  m.num_buses = static_cast<std::int8_t>(std::min<int>(s.num_buses, kMaxBuses));
  for (int b = 0; b < kMaxBuses; ++b) {
    const BusHealth& in = s.buses[b];
    hyq_lcm::lcmt_hyq_bus_health& out = m.buses[b];
    out.rx_frames = static_cast<std::int64_t>(in.rx_frames);
    out.tx_frames = static_cast<std::int64_t>(in.tx_frames);
    out.wkc_faults = static_cast<std::int64_t>(in.wkc_faults);
    out.missing = static_cast<std::int64_t>(in.missing);
    out.malformed = static_cast<std::int64_t>(in.malformed);
    out.error_frames = static_cast<std::int64_t>(in.error_frames);
    out.emcy = static_cast<std::int64_t>(in.emcy);
    out.bus_off = static_cast<std::int64_t>(in.bus_off);
    out.tx_failed = static_cast<std::int64_t>(in.tx_failed);
    out.driver_dropped = static_cast<std::int64_t>(in.driver_dropped);
    out.wkc_expected = static_cast<std::int32_t>(in.wkc_expected);
    out.wkc_received = static_cast<std::int32_t>(in.wkc_received);
  }
  m.num_devices = static_cast<std::int8_t>(std::min<int>(s.num_devices, kMaxDevices));
  CopyArray(s.device_state, &m.device_state);
  CopyArray(s.held_inputs, &m.held_inputs);
  CopyArray(s.max_held_in_row, &m.max_held_in_row);
  m.max_held_cycles = static_cast<std::int16_t>(std::min<std::uint32_t>(s.max_held_cycles, 32767));
  m.safety_events = static_cast<std::int64_t>(s.events);
  m.snapshots_dropped = static_cast<std::int64_t>(st.snapshots_dropped);
  m.events_dropped = static_cast<std::int64_t>(st.events_dropped);
  m.snapshots_published = static_cast<std::int64_t>(st.snapshots_published);
  m.publish_failures = static_cast<std::int64_t>(st.publish_failures);
  m.commands_received = static_cast<std::int64_t>(st.commands_received);
  m.commands_accepted = static_cast<std::int64_t>(st.commands_accepted);
  m.commands_rejected = static_cast<std::int64_t>(st.commands_rejected);
  m.commands_dropped = static_cast<std::int64_t>(st.commands_dropped);
  m.commands_unauthenticated = static_cast<std::int64_t>(st.commands_unauthenticated);
  m.commands_replayed = static_cast<std::int64_t>(st.commands_replayed);
}

void ToLcm(const SafetyEvent& e, hyq_lcm::lcmt_hyq_event* out) {
  hyq_lcm::lcmt_hyq_event& m = *out;
  m.utime = e.time_ns / 1000;
  m.cycle = static_cast<std::int64_t>(e.cycle);
  m.from_mode = static_cast<std::int8_t>(e.from);
  m.to_mode = static_cast<std::int8_t>(e.to);
  m.from_name = ToString(e.from);
  m.to_name = ToString(e.to);
  m.reason_code = static_cast<std::int16_t>(e.reason);
  m.reason = ToString(e.reason);
  m.joint = e.joint;
  m.bus = e.bus;
  m.detail.assign(e.detail.data(), strnlen(e.detail.data(), e.detail.size()));
}

}  // namespace hyq::servo
