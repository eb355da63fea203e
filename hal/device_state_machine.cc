#include "hal/device_state_machine.h"

#include <optional>

namespace hyq::hal {
namespace {

void SetError(DeviceRuntime& d, DeviceError e) noexcept {
  d.error = e;
  if (d.first_error == DeviceError::kNone) d.first_error = e;
}

// a fault found while configured: remember it, count it and latch it (blocks SAFE-OP -> OP)
DeviceState Fault(DeviceRuntime& d, DeviceError e, DeviceState next) noexcept {
  SetError(d, e);
  d.error_latched = true;
  ++d.counters.faults;
  return next;
}

bool HeartbeatLost(const DeviceRuntime& d, const StateMachineContext& ctx) noexcept {
  return d.last_heartbeat_ns >= 0 &&
         ctx.now_ns - d.last_heartbeat_ns > ctx.timing->heartbeat_timeout_ns;
}

void SendNmt(DeviceRuntime& d, NmtCommand cmd, StateMachineContext& ctx) noexcept {
  ctx.tx->Push(EncodeNmt(cmd, d.node));
}

void NoLeave(DeviceRuntime&, StateMachineContext&) noexcept {}

// INIT: the device is reset (NMT reset communication) and must announce itself with a boot-up.
DeviceState InitEnter(DeviceRuntime& d, StateMachineContext&) noexcept {
  d.start_sent = false;  // here: "reset sent"
  d.enable_requested = false;
  d.was_enabled = false;
  d.last_heartbeat_ns = -1;
  d.consecutive_valid = 0;
  d.consecutive_missed = 0;
  return DeviceState::kInit;
}
DeviceState InitFrame(DeviceRuntime& d, const DeviceEvent& e, StateMachineContext& ctx) noexcept {
  if (d.target == DeviceState::kInit) return DeviceState::kInit;
  if (e.kind == DeviceEventKind::kBootUp) return DeviceState::kPreOp;
  if (e.kind == DeviceEventKind::kHeartbeat) {
    if (e.nmt == NmtState::kPreOperational) return DeviceState::kPreOp;
    // configured by someone else (or by us before a fault): start over from a reset
    SendNmt(d, NmtCommand::kResetCommunication, ctx);
  }
  return DeviceState::kInit;
}
DeviceState InitCycle(DeviceRuntime& d, StateMachineContext& ctx) noexcept {
  if (d.target > DeviceState::kInit && !d.start_sent) {
    SendNmt(d, NmtCommand::kResetCommunication, ctx);
    d.start_sent = true;
  }
  return DeviceState::kInit;
}
DeviceState InitTimeout(DeviceRuntime& d, StateMachineContext& ctx) noexcept {
  SetError(d, DeviceError::kNoBootUp);
  ++d.counters.retries;
  SendNmt(d, NmtCommand::kResetCommunication, ctx);
  return DeviceState::kInit;
}

// Going down on request (e.g. the daemon's controlled stop): below SAFE-OP the device must stop
// its PDOs, so it is told with NMT enter-pre-operational (or reset for INIT).
DeviceState LeaveDownwards(DeviceRuntime& d, StateMachineContext& ctx) noexcept {
  SendNmt(d, d.target == DeviceState::kInit ? NmtCommand::kResetCommunication
                                            : NmtCommand::kEnterPreOperational, ctx);
  return d.target;
}

// PRE-OP: configuration; NMT start when SAFE-OP is wanted, SAFE-OP at the first valid inputs.
DeviceState PreOpEnter(DeviceRuntime& d, StateMachineContext&) noexcept {
  d.start_sent = false;
  d.enable_requested = false;
  d.consecutive_valid = 0;
  d.consecutive_missed = 0;
  return DeviceState::kPreOp;
}
DeviceState PreOpFrame(DeviceRuntime& d, const DeviceEvent& e, StateMachineContext&) noexcept {
  switch (e.kind) {
    case DeviceEventKind::kBootUp: d.start_sent = false; break;  // reset again: start again
    case DeviceEventKind::kInputs:
      if (d.target >= DeviceState::kSafeOp && d.start_sent) return DeviceState::kSafeOp;
      break;
    default: break;
  }
  return DeviceState::kPreOp;
}
DeviceState PreOpCycle(DeviceRuntime& d, StateMachineContext& ctx) noexcept {
  if (d.target < DeviceState::kPreOp) return d.target;
  if (HeartbeatLost(d, ctx)) {
    SetError(d, DeviceError::kHeartbeatLost);
    ++d.counters.faults;
    return DeviceState::kInit;
  }
  if (d.target >= DeviceState::kSafeOp && !d.start_sent) {
    SendNmt(d, NmtCommand::kStart, ctx);
    d.start_sent = true;
  }
  return DeviceState::kPreOp;
}
DeviceState PreOpTimeout(DeviceRuntime& d, StateMachineContext&) noexcept {
  SetError(d, DeviceError::kNoInputs);
  ++d.counters.faults;
  return DeviceState::kInit;
}

// What SAFE-OP and OP share: a boot-up (the device reset), a heartbeat other than OPERATIONAL or
// an EMCY other than "no error" is a fault (-> INIT, PRE-OP, SAFE-OP); nullopt for anything else.
std::optional<DeviceState> OperationalFault(DeviceRuntime& d, const DeviceEvent& e) noexcept {
  switch (e.kind) {
    case DeviceEventKind::kBootUp:
      return Fault(d, DeviceError::kUnexpectedReset, DeviceState::kInit);
    case DeviceEventKind::kHeartbeat:
      if (e.nmt != NmtState::kOperational)
        return Fault(d, DeviceError::kLeftOperational, DeviceState::kPreOp);
      break;
    case DeviceEventKind::kEmcy:
      if (e.emcy_code != emcy::kNoError) return Fault(d, DeviceError::kEmcy, DeviceState::kSafeOp);
      break;
    case DeviceEventKind::kInputs: break;
  }
  return std::nullopt;
}

// SAFE-OP: inputs valid, outputs held safe (0 N·m, not enabled). Enable when OP is wanted, no
// error is latched and the inputs have been valid for min_valid_cycles_for_op cycles.
DeviceState SafeOpEnter(DeviceRuntime& d, StateMachineContext&) noexcept {
  d.enable_requested = false;
  d.consecutive_missed = 0;  // SAFE-OP gets its own max_held_cycles window
  return DeviceState::kSafeOp;
}
DeviceState SafeOpFrame(DeviceRuntime& d, const DeviceEvent& e, StateMachineContext&) noexcept {
  if (const std::optional<DeviceState> next = OperationalFault(d, e)) return *next;
  if (e.kind == DeviceEventKind::kInputs && d.kind == DeviceKind::kActuator &&
      d.target == DeviceState::kOp && d.enable_requested && !d.error_latched &&
      (e.status & status_bit::kEnabled) != 0 && (e.status & status_bit::kFault) == 0)
    return DeviceState::kOp;
  return DeviceState::kSafeOp;
}
DeviceState SafeOpCycle(DeviceRuntime& d, StateMachineContext& ctx) noexcept {
  if (d.target < DeviceState::kSafeOp) return LeaveDownwards(d, ctx);
  if (HeartbeatLost(d, ctx)) return Fault(d, DeviceError::kHeartbeatLost, DeviceState::kInit);
  if (d.consecutive_missed > ctx.timing->max_held_cycles)
    return Fault(d, DeviceError::kInputsLost, DeviceState::kPreOp);
  if (d.fault_reset_grace > 0) --d.fault_reset_grace;  // the reset is on its way to the device
  else if (d.consecutive_valid > 0 && (d.last_status & status_bit::kFault) != 0 && !d.error_latched)
    Fault(d, DeviceError::kDeviceFault, DeviceState::kSafeOp);
  if (d.target == DeviceState::kOp && !d.error_latched &&
      d.consecutive_valid >= ctx.timing->min_valid_cycles_for_op) {
    if (d.kind == DeviceKind::kImu) return DeviceState::kOp;
    d.enable_requested = true;
  } else {
    d.enable_requested = false;
  }
  return DeviceState::kSafeOp;
}
DeviceState SafeOpTimeout(DeviceRuntime& d, StateMachineContext&) noexcept {
  d.enable_requested = false;
  return Fault(d, DeviceError::kEnableRefused, DeviceState::kSafeOp);
}

// OP: torque set-points applied. Any fault goes back to SAFE-OP (outputs safe) and latches.
DeviceState OpEnter(DeviceRuntime& d, StateMachineContext&) noexcept {
  d.was_enabled = true;
  return DeviceState::kOp;
}
DeviceState OpFrame(DeviceRuntime& d, const DeviceEvent& e, StateMachineContext&) noexcept {
  if (const std::optional<DeviceState> next = OperationalFault(d, e)) return *next;
  if (e.kind == DeviceEventKind::kInputs) {
    if ((e.status & status_bit::kFault) != 0)
      return Fault(d, DeviceError::kDeviceFault, DeviceState::kSafeOp);
    if (d.kind == DeviceKind::kActuator && (e.status & status_bit::kEnabled) == 0)
      return Fault(d, DeviceError::kDeviceDisabled, DeviceState::kSafeOp);
  }
  return DeviceState::kOp;
}
DeviceState OpCycle(DeviceRuntime& d, StateMachineContext& ctx) noexcept {
  if (d.target < DeviceState::kSafeOp) return LeaveDownwards(d, ctx);
  if (d.target < DeviceState::kOp) return d.target;
  if (HeartbeatLost(d, ctx)) return Fault(d, DeviceError::kHeartbeatLost, DeviceState::kInit);
  if (d.consecutive_missed > ctx.timing->max_held_cycles)
    return Fault(d, DeviceError::kInputsLost, DeviceState::kSafeOp);
  return DeviceState::kOp;
}
DeviceState OpTimeout(DeviceRuntime&, StateMachineContext&) noexcept { return DeviceState::kOp; }
void OpLeave(DeviceRuntime& d, StateMachineContext&) noexcept { d.enable_requested = false; }

bool TransitionPending(const DeviceRuntime& d) noexcept {
  if (d.target <= d.state) return false;
  return !(d.state == DeviceState::kSafeOp && d.error_latched);  // waits for an acknowledgement
}

}  // namespace

const StateHandlers kDeviceStateTable[kNumDeviceStates] = {
    {"INIT", InitEnter, InitFrame, InitCycle, InitTimeout, NoLeave},
    {"PRE-OP", PreOpEnter, PreOpFrame, PreOpCycle, PreOpTimeout, NoLeave},
    {"SAFE-OP", SafeOpEnter, SafeOpFrame, SafeOpCycle, SafeOpTimeout, NoLeave},
    {"OP", OpEnter, OpFrame, OpCycle, OpTimeout, OpLeave},
};

const char* ToString(DeviceState s) noexcept {
  const auto i = static_cast<std::size_t>(s);
  return i < kNumDeviceStates ? kDeviceStateTable[i].name : "unknown";
}

const char* ToString(DeviceError e) noexcept {
  switch (e) {
    case DeviceError::kNone: return "none";
    case DeviceError::kNoBootUp: return "no boot-up after NMT reset";
    case DeviceError::kNoInputs: return "no inputs after NMT start";
    case DeviceError::kInputsLost: return "inputs lost (working counter)";
    case DeviceError::kHeartbeatLost: return "heartbeat lost";
    case DeviceError::kUnexpectedReset: return "unexpected boot-up";
    case DeviceError::kLeftOperational: return "left NMT operational";
    case DeviceError::kEmcy: return "emergency message";
    case DeviceError::kDeviceFault: return "status word fault";
    case DeviceError::kEnableRefused: return "enable not confirmed";
    case DeviceError::kDeviceDisabled: return "device disabled itself";
  }
  return "unknown";
}

StateMachineTiming MakeStateMachineTiming(const TimingConfig& t) noexcept {
  StateMachineTiming s;
  s.state_timeout_ns = static_cast<std::int64_t>(t.state_timeout_s * 1e9);
  s.heartbeat_timeout_ns = static_cast<std::int64_t>(t.heartbeat_timeout_s * 1e9);
  s.max_held_cycles = static_cast<std::uint32_t>(t.max_held_cycles);
  s.min_valid_cycles_for_op = static_cast<std::uint32_t>(t.min_valid_cycles_for_op);
  return s;
}

void TransitionTo(DeviceRuntime& d, DeviceState next, StateMachineContext& ctx) noexcept {
  for (int hops = 0; hops < kNumDeviceStates && next != d.state; ++hops) {
    kDeviceStateTable[static_cast<std::size_t>(d.state)].on_leave(d, ctx);
    d.state = next;
    d.state_entered_ns = ctx.now_ns;
    next = kDeviceStateTable[static_cast<std::size_t>(d.state)].on_enter(d, ctx);
  }
}

void DispatchEvent(DeviceRuntime& d, const DeviceEvent& e, StateMachineContext& ctx) noexcept {
  switch (e.kind) {
    case DeviceEventKind::kBootUp:
      d.last_heartbeat_ns = ctx.now_ns;
      d.last_nmt = NmtState::kBootUp;
      break;
    case DeviceEventKind::kHeartbeat:
      d.last_heartbeat_ns = ctx.now_ns;
      d.last_nmt = e.nmt;
      break;
    case DeviceEventKind::kEmcy:
      ++d.counters.emcy;
      d.counters.last_emcy_code = e.emcy_code;
      break;
    case DeviceEventKind::kInputs: d.last_status = e.status; break;
  }
  const DeviceState next = kDeviceStateTable[static_cast<std::size_t>(d.state)].on_frame(d, e, ctx);
  TransitionTo(d, next, ctx);
}

void DispatchCycle(DeviceRuntime& d, StateMachineContext& ctx) noexcept {
  const StateHandlers& h = kDeviceStateTable[static_cast<std::size_t>(d.state)];
  DeviceState next = h.on_cycle(d, ctx);
  if (next == d.state && TransitionPending(d) &&
      ctx.now_ns - d.state_entered_ns > ctx.timing->state_timeout_ns) {
    next = h.on_timeout(d, ctx);
    if (next == d.state) d.state_entered_ns = ctx.now_ns;  // restart the timer (retry)
  }
  TransitionTo(d, next, ctx);
}

void RequestState(DeviceRuntime& d, DeviceState target) noexcept { d.target = target; }

void AcknowledgeFault(DeviceRuntime& d) noexcept {
  if (d.error_latched) {
    d.fault_reset_pending = true;
    d.fault_reset_grace = 2;
  }
  d.error_latched = false;
  d.first_error = DeviceError::kNone;
  d.consecutive_valid = 0;
}

}  // namespace hyq::hal
