#include "servo/runtime/safety_state_machine.h"

#include <algorithm>
#include <cstdio>

namespace hyq::servo {

inline constexpr int kNumServoModes = 6;  // ServoMode kInit .. kStopped

// The modes' handlers and their table (safety_state_machine.h): each returns the next mode and
// the event of the transition.
struct SafetyTable {
  using M = SafetyStateMachine;
  using Next = M::Next;
  using Occurrence = M::Occurrence;
  using Torque = SafetyDecision::Torque;

  static const M::ModeRow kRows[kNumServoModes];

  static Next Stay(M& m, const Occurrence&) noexcept { return {m.mode_}; }

  static Next ToStandby(M&, const Occurrence&) noexcept {
    return {ServoMode::kStandby, EventReason::kBringUpComplete, "all devices in OP"};
  }

  // enable only from STANDBY, and never once a stop was requested
  static Next RefuseEnable(M& m, const Occurrence&) noexcept {
    char d[kEventDetailSize];
    std::snprintf(d, sizeof d, "enable refused in %s (only from standby)", ToString(m.mode_));
    m.Note(EventReason::kCommandRejected, d);
    return {m.mode_};
  }
  static Next Enable(M& m, const Occurrence& o) noexcept {
    if (m.stop_) return RefuseEnable(m, o);
    return {ServoMode::kActive, o.reason, "controller torques applied"};
  }

  // never during a fault's sit-down: 0 N·m would drop the robot the sit-down is lowering
  static Next Disable(M& m, const Occurrence&) noexcept {
    if (m.fault_stop_ != StopClass::kNone) {
      m.Note(EventReason::kCommandRejected, "disable refused: sitting down after a fault");
      return {m.mode_};
    }
    return {ServoMode::kStandby, EventReason::kDisableCommand, "zero torque"};
  }

  static Next Damp(M& m, const Occurrence&) noexcept {
    m.damping_next_ = m.fault_stop_ != StopClass::kNone ? ServoMode::kFault : ServoMode::kStandby;
    m.damping_cut_ = false;
    return {ServoMode::kDamping, EventReason::kDampingCommand, "damping on command"};
  }

  static Next Acknowledge(M& m, const Occurrence& o) noexcept {
    if (!o.inputs_ok) {
      m.Note(EventReason::kCommandRejected, "acknowledge refused: the inputs are still faulty");
      return {m.mode_};
    }
    m.latched_ = 0;
    return {ServoMode::kStandby, EventReason::kAcknowledge, "faults acknowledged"};
  }

  // a controlled stop: from ACTIVE through DAMPING, from a resting mode at once
  static Next StopDamping(M& m, const Occurrence&) noexcept {
    m.damping_next_ = ServoMode::kStopped;
    m.damping_cut_ = false;
    return {ServoMode::kDamping, EventReason::kStopRequest, "controlled stop: damping"};
  }
  static Next StopNow(M&, const Occurrence&) noexcept {
    return {ServoMode::kStopped, EventReason::kStopRequest, "stop"};
  }

  static Next FaultTo(ServoMode to, M& m, const Occurrence& o) noexcept {
    const Fault& f = *o.fault;
    m.latched_ |= Bit(f);
    return {to, f.reason, f.detail.data(), f.joint, f.bus, o.stop};
  }
  static Next FaultDamping(M& m, const Occurrence& o) noexcept {
    m.damping_next_ = m.stop_ ? ServoMode::kStopped : ServoMode::kFault;
    m.damping_cut_ = true;
    return FaultTo(ServoMode::kDamping, m, o);
  }
  static Next FaultNow(M& m, const Occurrence& o) noexcept {
    return FaultTo(ServoMode::kFault, m, o);
  }
  // ACTIVE: by the stop's class, a cut damps at once; a controlled or degraded stop sits down
  // first (the caller's sit-down), recorded once per reason; the worst class so far stands
  static Next FaultInActive(M& m, const Occurrence& o) noexcept {
    if (o.stop == StopClass::kCut || !m.fault_sit_down_) return FaultDamping(m, o);
    const bool begins = m.fault_stop_ == StopClass::kNone;
    if (begins) m.fault_reason_ = o.fault->reason;
    const bool worse = o.stop > m.fault_stop_;
    m.fault_stop_ = std::max(m.fault_stop_, o.stop);
    if (worse) m.latched_ &= ~Bit(*o.fault);  // a worse class is news: record it again
    return RecordOnce(m, o);
  }
  // already safe: an event, once per reason until acknowledged
  static Next RecordOnce(M& m, const Occurrence& o) noexcept {
    const Fault& f = *o.fault;
    if ((m.latched_ & Bit(f)) != 0) return {m.mode_};
    m.latched_ |= Bit(f);
    SafetyEvent e;
    e.cycle = m.cycle_;
    e.time_ns = m.now_ns_;
    e.from = e.to = m.mode_;
    e.reason = f.reason;
    e.joint = f.joint;
    e.bus = f.bus;
    e.stop = o.stop;
    e.detail = f.detail;
    m.Push(e);
    return {m.mode_};
  }
  static Next FaultInDamping(M& m, const Occurrence& o) noexcept {
    m.damping_next_ = m.stop_ ? ServoMode::kStopped : ServoMode::kFault;
    return RecordOnce(m, o);
  }

  // the fault's sit-down is over: its damping, then FAULT (or STOPPED)
  static Next EndFaultSitDown(M& m, const Occurrence&) noexcept {
    if (m.fault_stop_ == StopClass::kNone) return {m.mode_};
    m.damping_next_ = m.stop_ ? ServoMode::kStopped : ServoMode::kFault;
    m.damping_cut_ = false;
    return {ServoMode::kDamping, m.fault_reason_, "sat down after the fault: damping",
            -1, -1, m.fault_stop_};
  }

  static Next DampingDone(M& m, const Occurrence&) noexcept {
    if (m.hold_damping_ ||
        static_cast<double>(m.cycles_in_mode_) * m.dt_ < m.limits_.damping_duration_s)
      return {m.mode_};
    return {m.stop_ ? ServoMode::kStopped : m.damping_next_,
            m.stop_ ? EventReason::kStopRequest : EventReason::kDampingDone,
            "damping finished: zero torque"};
  }

  static std::uint32_t Bit(const Fault& f) noexcept {
    return 1u << static_cast<unsigned>(f.reason);  // < kNumEventReasons <= 32
  }
};

// clang-format off
constexpr hal::DeviceState kPreOp = hal::DeviceState::kPreOp, kSafeOp = hal::DeviceState::kSafeOp;
const SafetyStateMachine::ModeRow SafetyTable::kRows[kNumServoModes] = {
  // torque, the devices asked for on entry;
  // bring-up   enable        disable  damp  acknowledge  stop         fault           damping timer
  /* INIT */     {Torque::kZero,       false, kPreOp,
     ToStandby, RefuseEnable, Stay,    Stay, Stay,        StopNow,     FaultNow,       Stay},
  /* STANDBY */  {Torque::kZero,       false, kPreOp,
     Stay,      Enable,       Stay,    Damp, Stay,        StopNow,     FaultNow,       Stay},
  /* ACTIVE */   {Torque::kController, false, kPreOp,
     Stay,      RefuseEnable, Disable, Damp, Stay,        StopDamping, FaultInActive,  Stay},
  /* DAMPING */  {Torque::kDamping,    false, kPreOp,
     Stay,      RefuseEnable, Stay,    Stay, Stay,        Stay,        FaultInDamping, DampingDone},
  /* FAULT */    {Torque::kZero,       true,  kSafeOp,
     Stay,      RefuseEnable, Stay,    Stay, Acknowledge, StopNow,     RecordOnce,     Stay},
  /* STOPPED */  {Torque::kZero,       true,  kPreOp,
     Stay,      RefuseEnable, Stay,    Stay, Stay,        Stay,        RecordOnce,     Stay},
};
// clang-format on

bool SafetyStateMachine::Dispatch(Handler ModeRow::*column, const Occurrence& o) noexcept {
  const Next next = (SafetyTable::kRows[static_cast<std::size_t>(mode_)].*column)(*this, o);
  if (next.mode == mode_) return false;
  Transition(next.mode, next.reason, next.joint, next.bus, next.detail, next.stop);
  return true;
}

void SafetyStateMachine::BeginCycle(std::uint64_t cycle, std::int64_t now_ns) noexcept {
  cycle_ = cycle;
  now_ns_ = now_ns;
  ++cycles_in_mode_;
  Dispatch(&ModeRow::on_damping_timer, {});
}

void SafetyStateMachine::BringUpComplete() noexcept { Dispatch(&ModeRow::on_bring_up, {}); }

bool SafetyStateMachine::Enable(EventReason why) noexcept {
  return Dispatch(&ModeRow::on_enable, {.reason = why});
}

bool SafetyStateMachine::Disable() noexcept {
  Dispatch(&ModeRow::on_disable, {});
  return mode_ == ServoMode::kStandby;  // disabled now, or already
}

bool SafetyStateMachine::Damp() noexcept { return Dispatch(&ModeRow::on_damp, {}); }

bool SafetyStateMachine::Acknowledge(bool inputs_ok) noexcept {
  return Dispatch(&ModeRow::on_acknowledge, {.inputs_ok = inputs_ok});
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

SafetyDecision SafetyStateMachine::Decide(bool devices_down, bool hold_damping) noexcept {
  const ModeRow& row = SafetyTable::kRows[static_cast<std::size_t>(mode_)];
  SafetyDecision d;
  d.mode = mode_;
  d.torque = row.torque;
  if (mode_ != decided_mode_) {
    if (row.request_devices) {
      d.request_devices = true;
      d.device_request = row.device_request;
    }
    if (mode_ == ServoMode::kStopped) stop_cycle_ = cycle_;
    decided_mode_ = mode_;
  }
  if (mode_ == ServoMode::kActive) ever_active_ = true;
  hold_damping_ = hold_damping && mode_ == ServoMode::kDamping;
  d.finished = mode_ == ServoMode::kStopped &&
               (devices_down || static_cast<double>(cycle_ - stop_cycle_) * dt_ > stop_timeout_s_);
  return d;
}

void SafetyStateMachine::Stop() noexcept {
  if (stop_) return;
  stop_ = true;
  Dispatch(&ModeRow::on_stop, {});
}

void SafetyStateMachine::Report(const Fault& f, StopClass stop) noexcept {
  if (!f || static_cast<std::size_t>(f.reason) >= kNumEventReasons) return;
  Dispatch(&ModeRow::on_fault, {.fault = &f, .stop = stop});
}

void SafetyStateMachine::EndFaultSitDown(bool stop) noexcept {
  if (mode_ != ServoMode::kActive) return;
  stop_ = stop_ || stop;
  const SafetyTable::Next next = SafetyTable::EndFaultSitDown(*this, {});
  if (next.mode != mode_)
    Transition(next.mode, next.reason, next.joint, next.bus, next.detail, next.stop);
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
                                    const char* detail, StopClass stop) noexcept {
  SafetyEvent e;
  e.cycle = cycle_;
  e.time_ns = now_ns_;
  e.from = mode_;
  e.to = to;
  e.reason = why;
  e.joint = static_cast<std::int16_t>(joint);
  e.bus = static_cast<std::int16_t>(bus);
  e.stop = stop;
  std::snprintf(e.detail.data(), e.detail.size(), "%s", detail);
  if (to != ServoMode::kDamping) damping_cut_ = false;
  if (to != ServoMode::kActive) fault_stop_ = StopClass::kNone;
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
