// The master-side state machine of one CAN device, in the EtherCAT style:
//
//   INIT ──boot-up──► PRE-OP ──NMT start, first inputs──► SAFE-OP ──enable confirmed──► OP
//    ▲  (NMT reset-comm,     (configuration; NMT start        (inputs valid, outputs       (torque
//    │   re-sent on timeout)   when SAFE-OP is wanted)          held safe: 0 N·m, disabled)  applied)
//    └── heartbeat lost / unexpected boot-up ◄── PRE-OP ◄── inputs lost ◄── SAFE-OP ◄── fault ┘
//
// A fault in OP (inputs missing for max_held_cycles, EMCY, status-word fault, device disabled
// itself) drops to SAFE-OP and latches the error: the device stays in SAFE-OP until the error is
// acknowledged (AcknowledgeFault), so outputs never come back on by themselves. Inputs lost in
// SAFE-OP drop to PRE-OP; a lost heartbeat or an unexpected boot-up drops to INIT, from where
// the machine retries the bring-up. Downward requests (target below the state) are obeyed at once.
//
// Written as a const table of handlers {on_enter, on_frame, on_cycle, on_timeout, on_leave},
// each returning the next state (lely src/co/nmt.c; house style §7). on_cycle runs once per
// cycle after the working-counter check; on_timeout runs when a transition towards the target
// has taken longer than the state's timeout. Every handler is noexcept and allocation-free.
#pragma once

#include <cstddef>
#include <cstdint>

#include "hal/can_channel.h"
#include "hal/hal_config.h"
#include "hal/protocol.h"

namespace hyq::hal {

enum class DeviceState : std::uint8_t { kInit, kPreOp, kSafeOp, kOp };
inline constexpr int kNumDeviceStates = 4;
const char* ToString(DeviceState s) noexcept;

enum class DeviceError : std::uint8_t {
  kNone,
  kNoBootUp,         // no boot-up / heartbeat after NMT reset within the state timeout
  kNoInputs,         // no TPDO after NMT start within the state timeout
  kInputsLost,       // inputs missing for more than max_held_cycles consecutive cycles
  kHeartbeatLost,    // no heartbeat within the consumer timeout
  kUnexpectedReset,  // boot-up message while configured
  kLeftOperational,  // heartbeat says the device is no longer NMT operational
  kEmcy,             // an emergency message (code in DeviceCounters::last_emcy_code)
  kDeviceFault,      // status word fault bit
  kEnableRefused,    // enable not confirmed within the state timeout
  kDeviceDisabled,   // the device dropped its enabled bit while in OP
};
const char* ToString(DeviceError e) noexcept;

/// What on_frame reacts to.
enum class DeviceEventKind : std::uint8_t { kBootUp, kHeartbeat, kInputs, kEmcy };
struct DeviceEvent {
  DeviceEventKind kind = DeviceEventKind::kHeartbeat;
  NmtState nmt = NmtState::kPreOperational;  // kHeartbeat
  std::uint16_t status = 0;                  // kInputs: the status word
  std::uint16_t emcy_code = 0;               // kEmcy
};

struct DeviceCounters {
  std::uint64_t valid = 0;         // cycles with exactly one valid TPDO for the current SYNC
  std::uint64_t missing = 0;       // expected inputs that did not arrive (held or not)
  std::uint64_t held = 0;          // cycles the last valid input was held (at most
                                   // max_held_cycles in a row; docs/hal.md)
  std::uint32_t max_held_in_row = 0;  // the longest run of held cycles since start
  std::uint64_t late = 0;          // TPDOs answering an older SYNC (stale, not used)
  std::uint64_t duplicate = 0;     // more than one TPDO for the same SYNC
  std::uint64_t malformed = 0;     // frames with this node's id that failed to decode
  std::uint64_t emcy = 0;
  std::uint64_t faults = 0;        // transitions down caused by an error
  std::uint64_t retries = 0;       // NMT reset re-sent in INIT
  std::uint16_t last_emcy_code = 0;
};

/// Run-time data of one device on one bus (configuration copied in at construction).
struct DeviceRuntime {
  // configuration
  DeviceKind kind = DeviceKind::kActuator;
  std::uint8_t node = 0;
  int joint = -1;
  int config_index = 0;  // index in BusConfig::devices
  // state machine
  DeviceState state = DeviceState::kInit;
  DeviceState target = DeviceState::kInit;
  DeviceError error = DeviceError::kNone;  // the last error (kept for the report)
  DeviceError first_error = DeviceError::kNone;  // the first since start / acknowledgement
  bool error_latched = false;              // blocks SAFE-OP -> OP until acknowledged
  bool fault_reset_pending = false;        // send control_bit::kFaultReset once
  std::uint8_t fault_reset_grace = 0;      // cycles the status fault bit is ignored after it
  std::int64_t state_entered_ns = 0;
  std::int64_t last_heartbeat_ns = -1;     // -1: none since the last NMT reset
  NmtState last_nmt = NmtState::kBootUp;
  bool start_sent = false;                 // NMT start sent in PRE-OP
  bool enable_requested = false;           // control_bit::kEnable in SAFE-OP (actuators)
  bool was_enabled = false;                // status kEnabled seen in OP
  // per cycle (working counter)
  bool expect_inputs = false;              // SYNC went out while the device was in SAFE-OP/OP
  std::uint8_t rx_count = 0;               // valid TPDOs for the current SYNC this cycle
  bool held = false;                       // expected, missing, within max_held_cycles in a row:
                                           // the last valid input is held (InputStatus::kHeld)
  std::uint32_t consecutive_missed = 0;
  std::uint32_t consecutive_valid = 0;
  std::uint16_t last_status = 0;
  ActuatorTpdo actuator_in;                // first valid TPDO this cycle
  ImuTpdo imu_in;
  DeviceCounters counters;
};

/// Timing in ns, derived once from TimingConfig.
struct StateMachineTiming {
  std::int64_t state_timeout_ns = 500'000'000;
  std::int64_t heartbeat_timeout_ns = 350'000'000;
  std::uint32_t max_held_cycles = 5;
  std::uint32_t min_valid_cycles_for_op = 5;
};
StateMachineTiming MakeStateMachineTiming(const TimingConfig& t) noexcept;

/// Where handlers queue the NMT commands they send (flushed by the bus's Write).
struct FrameQueue {
  CanFrame* frames = nullptr;
  std::size_t capacity = 0;
  std::size_t size = 0;
  std::uint64_t overflow = 0;
  void Push(const CanFrame& f) noexcept {
    if (size < capacity) frames[size++] = f;
    else ++overflow;
  }
};

struct StateMachineContext {
  std::int64_t now_ns = 0;
  const StateMachineTiming* timing = nullptr;
  FrameQueue* tx = nullptr;
};

using EnterFn = DeviceState (*)(DeviceRuntime&, StateMachineContext&) noexcept;
using FrameFn = DeviceState (*)(DeviceRuntime&, const DeviceEvent&, StateMachineContext&) noexcept;
using CycleFn = DeviceState (*)(DeviceRuntime&, StateMachineContext&) noexcept;
using TimeoutFn = DeviceState (*)(DeviceRuntime&, StateMachineContext&) noexcept;
using LeaveFn = void (*)(DeviceRuntime&, StateMachineContext&) noexcept;

struct StateHandlers {
  const char* name;
  EnterFn on_enter;
  FrameFn on_frame;
  CycleFn on_cycle;
  TimeoutFn on_timeout;
  LeaveFn on_leave;
};

/// The table, indexed by DeviceState.
extern const StateHandlers kDeviceStateTable[kNumDeviceStates];

/// Moves to `next` (on_leave, on_enter; on_enter may chain further, bounded).
void TransitionTo(DeviceRuntime& d, DeviceState next, StateMachineContext& ctx) noexcept;
/// Feeds an event to the current state's on_frame and follows the transition it returns.
void DispatchEvent(DeviceRuntime& d, const DeviceEvent& e, StateMachineContext& ctx) noexcept;
/// Runs on_cycle and, when a transition towards the target is overdue, on_timeout.
void DispatchCycle(DeviceRuntime& d, StateMachineContext& ctx) noexcept;
/// Sets the target; going down happens at the next DispatchCycle.
void RequestState(DeviceRuntime& d, DeviceState target) noexcept;
/// Clears a latched error (the next RPDO carries control_bit::kFaultReset; the status word's
/// fault bit is ignored for the two cycles the reset needs to reach the device and come back).
void AcknowledgeFault(DeviceRuntime& d) noexcept;

}  // namespace hyq::hal
