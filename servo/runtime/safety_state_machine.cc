#include "servo/runtime/safety_state_machine.h"

#include <cstdio>

namespace hyq::servo {

void SafetyStateMachine::BeginCycle(std::uint64_t cycle, std::int64_t now_ns) noexcept {
  cycle_ = cycle;
  now_ns_ = now_ns;
  ++cycles_in_mode_;
  if (mode_ == ServoMode::kDamping && !hold_damping_ &&
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
    char d[kEventDetailSize];
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

bool SafetyStateMachine::RequestAcknowledge() noexcept {
  if (mode_ != ServoMode::kFault) {
    char d[kEventDetailSize];
    std::snprintf(d, sizeof d, "acknowledge refused in %s (only in fault)", ToString(mode_));
    Note(EventReason::kCommandRejected, d);
    return false;
  }
  ack_pending_ = true;
  ack_deadline_cycle_ = cycle_ + static_cast<std::uint64_t>(1.0 / dt_);  // 1 s to come back
  return true;
}

bool SafetyStateMachine::expects_devices_in_op() const noexcept {
  return mode_ == ServoMode::kStandby || mode_ == ServoMode::kActive ||
         (mode_ == ServoMode::kDamping && !ack_pending_);
}

bool SafetyStateMachine::MaybeAutoEnable(bool estimate_ready) noexcept {
  if (!auto_enable_ || mode_ != ServoMode::kStandby || stop_ || ever_active_ || !estimate_ready)
    return false;
  return Enable(EventReason::kEnableCommand);
}

void SafetyStateMachine::Update(const CycleFacts& f) noexcept {
  if (!ack_pending_) return;
  if (f.devices_in_op && f.inputs_ok) {
    ack_pending_ = !Acknowledge(true);
  } else if (cycle_ > ack_deadline_cycle_) {
    ack_pending_ = false;
    Note(EventReason::kCommandRejected, "acknowledge failed: devices not back in OP within 1 s");
  }
}

SafetyDecision SafetyStateMachine::Decide(bool devices_down) noexcept {
  SafetyDecision d;
  d.mode = mode_;
  d.torque = mode_ == ServoMode::kActive    ? SafetyDecision::Torque::kController
             : mode_ == ServoMode::kDamping ? SafetyDecision::Torque::kDamping
                                            : SafetyDecision::Torque::kZero;
  if (mode_ != decided_mode_) {
    if (mode_ == ServoMode::kFault) {
      d.request_devices = true;
      d.device_request = hal::DeviceState::kSafeOp;  // outputs disabled
    }
    if (mode_ == ServoMode::kStopped) {
      d.request_devices = true;
      d.device_request = hal::DeviceState::kPreOp;
      stop_cycle_ = cycle_;
    }
    decided_mode_ = mode_;
  }
  if (mode_ == ServoMode::kActive) ever_active_ = true;
  d.finished = mode_ == ServoMode::kStopped &&
               (devices_down || static_cast<double>(cycle_ - stop_cycle_) * dt_ > stop_timeout_s_);
  return d;
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
  if (!f || static_cast<std::size_t>(f.reason) >= kNumEventReasons) return;
  const std::uint32_t bit = 1u << static_cast<unsigned>(f.reason);  // < kNumEventReasons <= 32
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
  hold_damping_ = false;
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
