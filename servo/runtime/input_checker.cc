#include "servo/runtime/input_checker.h"

#include <cmath>
#include <string_view>

namespace hyq::servo {

namespace {

// "lf_haa" for joint 0 (the HAL's joint name without "_joint"), for event details.
std::string_view JointLabel(int j) noexcept {
  std::string_view name = hal::JointName(j);
  if (name.ends_with("_joint")) name.remove_suffix(6);
  return name.empty() ? std::string_view("?") : name;
}

Fault ImuFault(Fault f) noexcept {
  f.imu = true;
  return f;
}

}  // namespace

InputChecker::InputChecker(const SafetyLimits& limits, const hal::HalConfig& hal)
    : limits_(limits), max_held_cycles_(static_cast<std::uint32_t>(hal.timing.max_held_cycles)) {
  for (int j = 0; j < hal::kNumJoints; ++j) {
    const auto& c = hal.joints[static_cast<std::size_t>(j)];
    q_min_[static_cast<std::size_t>(j)] = c.q_min_rad - limits.position_margin_rad;
    q_max_[static_cast<std::size_t>(j)] = c.q_max_rad + limits.position_margin_rad;
  }
}

void InputChecker::Reset(const hal::Hal& hal) noexcept {
  have_last_.fill(false);
  for (std::size_t b = 0; b < hal.num_buses() && b < malformed_.size(); ++b) {
    const auto& c = hal.bus(b).counters();
    malformed_[b] = c.malformed;
    bus_off_[b] = c.bus_off;
    error_frames_[b] = c.error_frames;
    foreign_[b] = c.foreign_master;
  }
}

Fault InputChecker::Check(const hal::Hal& hal, hal::HalStatus read_status,
                          bool expect_op) noexcept {
  Fault first;
  auto note = [&first](const Fault& f) {
    if (!first) first = f;
  };
  // buses: bus-off and corrupted frames (counter increments since the last cycle)
  for (std::size_t b = 0; b < hal.num_buses() && b < malformed_.size(); ++b) {
    const auto& c = hal.bus(b).counters();
    const int bi = static_cast<int>(b);
    if (c.bus_off != bus_off_[b] || hal.bus(b).channel().counters().bus_state ==
                                        hal::BusState::kBusOff)
      note(MakeFault(EventReason::kBusOff, -1, bi, "bus %s is bus-off",
                     hal.config().buses[b].name.c_str()));
    if (c.malformed != malformed_[b]) {
      // the board whose frame it was (the HAL's last faulty node): the stop's class needs it
      const hal::DeviceRuntime* from = nullptr;
      for (const auto& d : hal.bus(b).devices())
        if (d.node == c.last_fault_node) from = &d;
      Fault f = MakeFault(EventReason::kCorruptFrames, from != nullptr ? from->joint : -1, bi,
                          "bus %s: %llu malformed frame(s), the last from node %u",
                          hal.config().buses[b].name.c_str(),
                          static_cast<unsigned long long>(c.malformed - malformed_[b]),
                          static_cast<unsigned>(c.last_fault_node));
      f.imu = from != nullptr && from->kind == hal::DeviceKind::kImu;
      note(f);
    }
    if (c.foreign_master != foreign_[b])
      note(MakeFault(EventReason::kForeignMaster, -1, bi,
                     "bus %s: %llu SYNC/NMT/RPDO frame(s) the daemon did not send (last id 0x%03x)",
                     hal.config().buses[b].name.c_str(),
                     static_cast<unsigned long long>(c.foreign_master - foreign_[b]),
                     static_cast<unsigned>(c.last_foreign_id)));
    malformed_[b] = c.malformed;
    bus_off_[b] = c.bus_off;
    error_frames_[b] = c.error_frames;
    foreign_[b] = c.foreign_master;
  }
  if (read_status == hal::HalStatus::kBusOff && !first)
    note(MakeFault(EventReason::kBusOff, -1, -1, "the HAL reports bus-off"));

  // devices: all in OP once brought up
  if (expect_op) {
    for (std::size_t b = 0; b < hal.num_buses(); ++b)
      for (const auto& d : hal.bus(b).devices())
        if (d.state != hal::DeviceState::kOp) {
          // past the hold limit (one policy, docs/hal.md) the device leaves OP for missing
          // inputs: that is the reason, not a fault of the device
          Fault f = MakeFault(d.error == hal::DeviceError::kInputsLost ? EventReason::kInputMissing
                                                                       : EventReason::kDeviceFault,
                              d.joint, static_cast<int>(b),
                              "device node %u on bus %s left OP (%s, error %s)", d.node,
                              hal.config().buses[b].name.c_str(), hal::ToString(d.state),
                              hal::ToString(d.error));
          f.imu = d.kind == hal::DeviceKind::kImu;
          note(f);
        }
  }

  const auto& image = hal.image();
  for (int j = 0; j < hal::kNumJoints; ++j) {
    const auto ju = static_cast<std::size_t>(j);
    const auto& in = image.joints[ju];
    const std::string_view label = JointLabel(j);
    switch (in.status) {
      case hal::InputStatus::kValid:
        break;
      case hal::InputStatus::kDeviceFault:
        note(MakeFault(EventReason::kDeviceFault, j, -1, "%.*s reports a fault (status 0x%04x)",
                       static_cast<int>(label.size()), label.data(), in.status_word));
        break;
      case hal::InputStatus::kHeld:
        continue;  // the last valid values, checked when they were fresh (docs/hal.md)
      case hal::InputStatus::kMissing:
      case hal::InputStatus::kDuplicate:
      case hal::InputStatus::kNotOperational:
        if (in.age_cycles > max_held_cycles_)
          note(MakeFault(EventReason::kInputMissing, j, -1, "%.*s: no fresh input for %u cycles (%s)",
                         static_cast<int>(label.size()), label.data(), in.age_cycles, hal::ToString(in.status)));
        continue;  // stale values: nothing more to check
    }
    if (!std::isfinite(in.position_rad) || !std::isfinite(in.velocity_rad_s) ||
        !std::isfinite(in.torque_Nm)) {
      note(MakeFault(EventReason::kNonFiniteInput, j, -1, "%.*s: non-finite reading q=%g qd=%g tau=%g",
                     static_cast<int>(label.size()), label.data(), in.position_rad, in.velocity_rad_s, in.torque_Nm));
      continue;
    }
    if (in.position_rad < q_min_[ju] || in.position_rad > q_max_[ju])
      note(MakeFault(EventReason::kOutOfRange, j, -1, "%.*s: q=%.4f rad outside [%.4f, %.4f]",
                     static_cast<int>(label.size()), label.data(), in.position_rad, q_min_[ju], q_max_[ju]));
    if (std::abs(in.velocity_rad_s) > limits_.max_velocity_rad_s)
      note(MakeFault(EventReason::kOutOfRange, j, -1, "%.*s: qd=%.3f rad/s, |qd| above %.3f",
                     static_cast<int>(label.size()), label.data(), in.velocity_rad_s, limits_.max_velocity_rad_s));
    if (std::abs(in.torque_Nm) > limits_.max_measured_torque_Nm)
      note(MakeFault(EventReason::kOutOfRange, j, -1, "%.*s: measured tau=%.1f N m, |tau| above %.1f",
                     static_cast<int>(label.size()), label.data(), in.torque_Nm, limits_.max_measured_torque_Nm));
    if (have_last_[ju] && std::abs(in.position_rad - last_q_[ju]) > limits_.max_position_jump_rad)
      note(MakeFault(EventReason::kInputJump, j, -1, "%.*s: q jumped %.4f rad in one cycle (max %.4f)",
                     static_cast<int>(label.size()), label.data(), in.position_rad - last_q_[ju], limits_.max_position_jump_rad));
    last_q_[ju] = in.position_rad;
    have_last_[ju] = true;
  }

  const auto& imu = image.imu;
  if (imu.status == hal::InputStatus::kValid) {
    double g2 = 0.0, a2 = 0.0;
    bool finite = true;
    for (int i = 0; i < 3; ++i) {
      finite = finite && std::isfinite(imu.gyro_rad_s[static_cast<std::size_t>(i)]) &&
               std::isfinite(imu.accel_m_s2[static_cast<std::size_t>(i)]);
      g2 += imu.gyro_rad_s[static_cast<std::size_t>(i)] * imu.gyro_rad_s[static_cast<std::size_t>(i)];
      a2 += imu.accel_m_s2[static_cast<std::size_t>(i)] * imu.accel_m_s2[static_cast<std::size_t>(i)];
    }
    if (!finite)
      note(ImuFault(MakeFault(EventReason::kNonFiniteInput, -1, -1, "IMU: non-finite reading")));
    else if (std::sqrt(g2) > limits_.max_gyro_rad_s)
      note(ImuFault(MakeFault(EventReason::kOutOfRange, -1, -1, "IMU: |gyro|=%.2f rad/s above %.2f",
                              std::sqrt(g2), limits_.max_gyro_rad_s)));
    else if (std::sqrt(a2) > limits_.max_accel_m_s2)
      note(ImuFault(MakeFault(EventReason::kOutOfRange, -1, -1, "IMU: |accel|=%.1f m/s2 above %.1f",
                              std::sqrt(a2), limits_.max_accel_m_s2)));
  } else if (imu.status == hal::InputStatus::kDeviceFault) {
    note(ImuFault(MakeFault(EventReason::kDeviceFault, -1, -1, "IMU reports a fault (status 0x%04x)",
                            imu.status_word)));
  } else if (imu.status != hal::InputStatus::kHeld && imu.age_cycles > max_held_cycles_) {
    note(ImuFault(MakeFault(EventReason::kInputMissing, -1, -1, "IMU: no fresh input for %u cycles (%s)",
                            imu.age_cycles, hal::ToString(imu.status))));
  }
  return first;
}

}  // namespace hyq::servo
