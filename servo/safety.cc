#include "servo/safety.h"

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <string_view>

namespace hyq::servo {

Fault MakeFault(EventReason reason, int joint, int bus, const char* fmt, ...) noexcept {
  Fault f;
  f.reason = reason;
  f.joint = static_cast<std::int16_t>(joint);
  f.bus = static_cast<std::int16_t>(bus);
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(f.detail.data(), f.detail.size(), fmt, args);
  va_end(args);
  return f;
}

namespace {

// "lf_haa" for joint 0 (the HAL's joint name without "_joint"), for event details.
std::string_view JointLabel(int j) noexcept {
  std::string_view name = hal::JointName(j);
  if (name.ends_with("_joint")) name.remove_suffix(6);
  return name.empty() ? std::string_view("?") : name;
}

}  // namespace

InputChecker::InputChecker(const SafetyLimits& limits, const hal::HalConfig& hal)
    : limits_(limits) {
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
    if (c.malformed != malformed_[b])
      note(MakeFault(EventReason::kCorruptFrames, -1, bi, "bus %s: %llu malformed frame(s)",
                     hal.config().buses[b].name.c_str(),
                     static_cast<unsigned long long>(c.malformed - malformed_[b])));
    malformed_[b] = c.malformed;
    bus_off_[b] = c.bus_off;
    error_frames_[b] = c.error_frames;
  }
  if (read_status == hal::HalStatus::kBusOff && !first)
    note(MakeFault(EventReason::kBusOff, -1, -1, "the HAL reports bus-off"));

  // devices: all in OP once brought up
  if (expect_op) {
    for (std::size_t b = 0; b < hal.num_buses(); ++b)
      for (const auto& d : hal.bus(b).devices())
        if (d.state != hal::DeviceState::kOp)
          note(MakeFault(EventReason::kDeviceFault, d.joint, static_cast<int>(b),
                         "device node %u on bus %s left OP (%s, error %s)", d.node,
                         hal.config().buses[b].name.c_str(), hal::ToString(d.state),
                         hal::ToString(d.error)));
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
      case hal::InputStatus::kMissing:
      case hal::InputStatus::kDuplicate:
      case hal::InputStatus::kNotOperational:
        if (in.age_cycles >= static_cast<std::uint32_t>(limits_.max_missing_cycles))
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
      note(MakeFault(EventReason::kOutOfRange, j, -1, "%.*s: |qd|=%.3f rad/s above %.3f",
                     static_cast<int>(label.size()), label.data(), in.velocity_rad_s, limits_.max_velocity_rad_s));
    if (std::abs(in.torque_Nm) > limits_.max_measured_torque_Nm)
      note(MakeFault(EventReason::kOutOfRange, j, -1, "%.*s: |tau measured|=%.1f N m above %.1f",
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
      note(MakeFault(EventReason::kNonFiniteInput, -1, -1, "IMU: non-finite reading"));
    else if (std::sqrt(g2) > limits_.max_gyro_rad_s)
      note(MakeFault(EventReason::kOutOfRange, -1, -1, "IMU: |gyro|=%.2f rad/s above %.2f",
                     std::sqrt(g2), limits_.max_gyro_rad_s));
    else if (std::sqrt(a2) > limits_.max_accel_m_s2)
      note(MakeFault(EventReason::kOutOfRange, -1, -1, "IMU: |accel|=%.1f m/s2 above %.1f",
                     std::sqrt(a2), limits_.max_accel_m_s2));
  } else if (imu.status == hal::InputStatus::kDeviceFault) {
    note(MakeFault(EventReason::kDeviceFault, -1, -1, "IMU reports a fault (status 0x%04x)",
                   imu.status_word));
  } else if (imu.age_cycles >= static_cast<std::uint32_t>(limits_.max_missing_cycles)) {
    note(MakeFault(EventReason::kInputMissing, -1, -1, "IMU: no fresh input for %u cycles (%s)",
                   imu.age_cycles, hal::ToString(imu.status)));
  }
  return first;
}

// --- the state machine -------------------------------------------------------------------------

void SafetyStateMachine::BeginCycle(std::uint64_t cycle, std::int64_t now_ns) noexcept {
  cycle_ = cycle;
  now_ns_ = now_ns;
  ++cycles_in_mode_;
  if (mode_ == ServoMode::kDamping &&
      static_cast<double>(cycles_in_mode_) * dt_ >= limits_.damping_duration_s) {
    const ServoMode next = stop_ ? ServoMode::kStopped : damping_next_;
    Transition(next, stop_ ? EventReason::kStopRequest : EventReason::kDampingDone, -1, -1,
               "damping finished: zero torque");
  }
}

void SafetyStateMachine::BringUpComplete() noexcept {
  if (mode_ == ServoMode::kInit)
    Transition(ServoMode::kStandby, EventReason::kBringUpComplete, -1, -1, "all devices in OP");
}

bool SafetyStateMachine::Enable(EventReason why) noexcept {
  if (mode_ != ServoMode::kStandby || stop_) {
    char d[96];
    std::snprintf(d, sizeof d, "enable refused in %s (only from standby)", ToString(mode_));
    Note(EventReason::kCommandRejected, d);
    return false;
  }
  Transition(ServoMode::kActive, why, -1, -1, "controller torques applied");
  return true;
}

bool SafetyStateMachine::Disable() noexcept {
  if (mode_ != ServoMode::kActive) return mode_ == ServoMode::kStandby;
  Transition(ServoMode::kStandby, EventReason::kDisableCommand, -1, -1, "zero torque");
  return true;
}

bool SafetyStateMachine::Damp() noexcept {
  if (mode_ != ServoMode::kActive && mode_ != ServoMode::kStandby) return false;
  damping_next_ = ServoMode::kStandby;
  Transition(ServoMode::kDamping, EventReason::kDampingCommand, -1, -1, "damping on command");
  return true;
}

bool SafetyStateMachine::Acknowledge(bool inputs_ok) noexcept {
  if (mode_ != ServoMode::kFault) return false;
  if (!inputs_ok) {
    Note(EventReason::kCommandRejected, "acknowledge refused: the inputs are still faulty");
    return false;
  }
  latched_ = 0;
  Transition(ServoMode::kStandby, EventReason::kAcknowledge, -1, -1, "faults acknowledged");
  return true;
}

void SafetyStateMachine::Stop() noexcept {
  if (stop_) return;
  stop_ = true;
  if (mode_ == ServoMode::kActive) {
    damping_next_ = ServoMode::kStopped;
    Transition(ServoMode::kDamping, EventReason::kStopRequest, -1, -1, "controlled stop: damping");
  } else if (mode_ != ServoMode::kDamping && mode_ != ServoMode::kStopped) {
    Transition(ServoMode::kStopped, EventReason::kStopRequest, -1, -1, "stop");
  }
}

void SafetyStateMachine::Report(const Fault& f) noexcept {
  if (!f) return;
  const std::uint32_t bit = 1u << (static_cast<unsigned>(f.reason) & 31u);
  switch (mode_) {
    case ServoMode::kActive:
      damping_next_ = stop_ ? ServoMode::kStopped : ServoMode::kFault;
      latched_ |= bit;
      Transition(ServoMode::kDamping, f.reason, f.joint, f.bus, f.detail.data());
      return;
    case ServoMode::kStandby:
    case ServoMode::kInit:
      latched_ |= bit;
      Transition(ServoMode::kFault, f.reason, f.joint, f.bus, f.detail.data());
      return;
    case ServoMode::kDamping:
      damping_next_ = stop_ ? ServoMode::kStopped : ServoMode::kFault;
      [[fallthrough]];
    case ServoMode::kFault:
    case ServoMode::kStopped:
      if ((latched_ & bit) == 0) {
        latched_ |= bit;
        SafetyEvent e;
        e.cycle = cycle_;
        e.time_ns = now_ns_;
        e.from = e.to = mode_;
        e.reason = f.reason;
        e.joint = f.joint;
        e.bus = f.bus;
        e.detail = f.detail;
        Push(e);
      }
      return;
  }
}

void SafetyStateMachine::Note(EventReason reason, const char* detail) noexcept {
  SafetyEvent e;
  e.cycle = cycle_;
  e.time_ns = now_ns_;
  e.from = e.to = mode_;
  e.reason = reason;
  std::snprintf(e.detail.data(), e.detail.size(), "%s", detail);
  Push(e);
}

void SafetyStateMachine::Transition(ServoMode to, EventReason why, int joint, int bus,
                                    const char* detail) noexcept {
  SafetyEvent e;
  e.cycle = cycle_;
  e.time_ns = now_ns_;
  e.from = mode_;
  e.to = to;
  e.reason = why;
  e.joint = static_cast<std::int16_t>(joint);
  e.bus = static_cast<std::int16_t>(bus);
  std::snprintf(e.detail.data(), e.detail.size(), "%s", detail);
  mode_ = to;
  cycles_in_mode_ = 0;
  Push(e);
}

void SafetyStateMachine::Push(const SafetyEvent& e) noexcept {
  ++events_;
  if (size_ == ring_.size()) {  // keep the newest: drop the oldest
    head_ = (head_ + 1) % ring_.size();
    --size_;
    ++dropped_;
  }
  ring_[(head_ + size_) % ring_.size()] = e;
  ++size_;
}

bool SafetyStateMachine::Take(SafetyEvent* e) noexcept {
  if (size_ == 0) return false;
  *e = ring_[head_];
  head_ = (head_ + 1) % ring_.size();
  --size_;
  return true;
}

}  // namespace hyq::servo
