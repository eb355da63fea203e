// The daemon's mode state machine (docs/servo.md, "Safety"): every decision about the mode and
// what it means for the outputs is made here. A const table, one row per mode (the torque, the
// devices' state asked for on entry and, per event, a handler returning the next mode), in the
// manner of hal/device_state_machine.cc:
//
//            bring-up  enable   disable  damp     acknowledge  stop     fault    damping timer
//   INIT     STANDBY   refused  -        -        -            STOPPED  FAULT    -
//   STANDBY  -         ACTIVE¹  -        DAMPING  -            STOPPED  FAULT    -
//   ACTIVE   -         refused  STANDBY⁶ DAMPING  -            DAMPING  ⁷        -
//   DAMPING  -         refused  -        -        -            -²       -³       ⁴
//   FAULT    -         refused  -        -        STANDBY⁵     STOPPED  -³       -
//   STOPPED  -         refused  -        -        -            -        -³       -
//
//   ¹ refused once a stop was requested. ² DAMPING then ends in STOPPED. ³ an event, once per
//   reason until acknowledged (in DAMPING the damping then ends in FAULT). ⁴ after
//   damping_duration_s, unless the caller holds it (the sit-down's settling, motion_sequencer.h):
//   STOPPED once a stop was requested, else FAULT when a fault caused it, STANDBY after a damp
//   command. ⁵ with clean inputs; else refused. ⁶ refused during a fault's sit-down. ⁷ by the
//   fault's stop class (stop_class.h): cut → DAMPING at once (category 0); controlled or
//   degraded → stays ACTIVE while the caller sits the robot down (fault_stop(); category 1),
//   then DAMPING (EndFaultSitDown) and FAULT; a later cut fault during it → DAMPING at once.
//   "-": no transition, no event; a refusal is an event.
//
// STANDBY: devices in OP, 0 N·m. ACTIVE: the controller's torque. DAMPING: τ = −D q̇ on the joints
// whose inputs are valid, 0 N·m on the others. FAULT: 0 N·m and the devices asked to SAFE-OP
// (outputs disabled) until an acknowledgement with the faults gone. STOPPED: 0 N·m, the devices
// asked to PRE-OP; the run is finished once they are there (or the stop timeout passed). Every
// transition, every refusal and every new fault while already safe is a SafetyEvent with a reason
// (fixed ring, drained by the loop).
//
// The acknowledgement is a handshake: in FAULT the loop asks the devices back to OP
// (RequestAcknowledge) and the state machine returns to STANDBY once they are all in OP with
// clean inputs, or gives up after a second. Auto-enable (operation.auto_enable) enables once, as
// soon as the state estimate is ready.
//
// Nothing here allocates, locks or throws after construction.
#pragma once

#include <array>
#include <cstdint>

#include "hal/device_state_machine.h"
#include "servo/common/servo_types.h"
#include "servo/runtime/fault.h"
#include "servo/runtime/safety_limits.h"

namespace hyq::servo {

/// What this cycle's mode means for the outputs (SafetyStateMachine::Decide).
struct SafetyDecision {
  enum class Torque : std::uint8_t { kController, kDamping, kZero };
  ServoMode mode = ServoMode::kInit;
  Torque torque = Torque::kZero;
  /// The mode changed into FAULT (→ SAFE-OP) or STOPPED (→ PRE-OP): ask every device for this.
  bool request_devices = false;
  hal::DeviceState device_request = hal::DeviceState::kPreOp;
  /// STOPPED and the devices down (or the stop timeout passed): the runner may return.
  bool finished = false;
};

/// What the state machine is told about the cycle, once the inputs have been checked.
struct CycleFacts {
  bool inputs_ok = false;       // the input checks found nothing
  bool devices_in_op = false;   // every device in OP
};

class SafetyStateMachine {
 public:
  static constexpr std::size_t kEventCapacity = 64;

  /// `dt`: the period; `auto_enable`: STANDBY → ACTIVE once without a command; `stop_timeout_s`:
  /// how long STOPPED waits for the devices to reach PRE-OP.
  SafetyStateMachine(const SafetyLimits& limits, double dt, bool auto_enable = false,
                     double stop_timeout_s = 3.0)
      : limits_(limits), dt_(dt), auto_enable_(auto_enable), stop_timeout_s_(stop_timeout_s) {}

  ServoMode mode() const noexcept { return mode_; }
  /// Cycles spent in the current mode.
  std::uint64_t cycles_in_mode() const noexcept { return cycles_in_mode_; }

  /// Start of every cycle: its number and time (for events) and the damping timer.
  void BeginCycle(std::uint64_t cycle, std::int64_t now_ns) noexcept;

  /// Bring-up done: INIT → STANDBY.
  void BringUpComplete() noexcept;
  /// Operator requests. Each returns whether it was accepted; a refused request is an event
  /// (kCommandRejected) naming the mode it was refused in.
  bool Enable(EventReason why) noexcept;      // STANDBY → ACTIVE
  bool Disable() noexcept;                    // ACTIVE → STANDBY
  bool Damp() noexcept;                       // ACTIVE / STANDBY → DAMPING
  /// FAULT → STANDBY; `inputs_ok` says whether the inputs are clean again.
  bool Acknowledge(bool inputs_ok) noexcept;
  /// Starts the acknowledgement handshake (only in FAULT; else refused with an event). The
  /// caller asks the devices back to OP when this returns true.
  bool RequestAcknowledge() noexcept;
  /// Waiting for the devices after an acknowledgement.
  bool acknowledge_pending() const noexcept { return ack_pending_; }
  /// Whether the devices are expected in OP this cycle (for the input checks).
  bool expects_devices_in_op() const noexcept;
  /// Auto-enable: true when it enabled now (the caller starts the reference).
  bool MaybeAutoEnable(bool estimate_ready) noexcept;
  /// After the input checks: finishes (or gives up) a pending acknowledgement.
  void Update(const CycleFacts& facts) noexcept;
  /// Controlled stop: ACTIVE → DAMPING → STOPPED, anything else → STOPPED.
  void Stop() noexcept;
  /// A fault of stop class `stop` (stop_class.h): in ACTIVE a cut → DAMPING, a controlled or
  /// degraded stop → a sit-down under way in ACTIVE (fault_stop(); when the caller has no
  /// sit-down, see SetFaultSitDown, → DAMPING); STANDBY → FAULT; while already safe, only an event
  /// (once per reason until acknowledged).
  void Report(const Fault& f, StopClass stop = StopClass::kCut) noexcept;
  /// Whether the caller sits the robot down on a controlled or degraded stop (default: no, every
  /// fault damps at once).
  void SetFaultSitDown(bool enabled) noexcept { fault_sit_down_ = enabled; }
  /// The stop class of the fault sit-down under way in ACTIVE (kNone: none).
  StopClass fault_stop() const noexcept { return fault_stop_; }
  /// The fault sit-down is over: ACTIVE → DAMPING (the sit-down's damping, held by the caller),
  /// then FAULT, or STOPPED once a stop was requested (`stop`: one is now).
  void EndFaultSitDown(bool stop) noexcept;
  /// Records an event without a transition (applied commands, refused commands).
  void Note(EventReason reason, const char* detail) noexcept;

  /// The outputs of this cycle, after the controller: which torque, which device requests,
  /// whether the stop is complete (`devices_down`: every device in PRE-OP or below).
  /// `hold_damping`: DAMPING does not end on its timer at the next cycle's start (the sit-down's
  /// damping, until the robot rests; bounded by the caller); any transition drops the hold.
  SafetyDecision Decide(bool devices_down, bool hold_damping = false) noexcept;

  /// Events not yet taken by the loop, oldest first; Take() removes one.
  bool Take(SafetyEvent* e) noexcept;
  std::uint64_t events() const noexcept { return events_; }
  std::uint64_t events_dropped() const noexcept { return dropped_; }
  /// Whether the current DAMPING ends in FAULT (a fault caused it) rather than STANDBY/STOPPED.
  bool damping_for_fault() const noexcept { return damping_next_ == ServoMode::kFault; }
  /// Whether the current DAMPING is a cut (category 0): a fault's damping without a sit-down.
  bool damping_cut() const noexcept { return mode_ == ServoMode::kDamping && damping_cut_; }
  bool stop_requested() const noexcept { return stop_; }
  bool ever_active() const noexcept { return ever_active_; }

 private:
  friend struct SafetyTable;  // the modes' handlers (safety_state_machine.cc)
  // what a handler is told: the event's particulars
  struct Occurrence {
    EventReason reason = EventReason::kNone;  // enable: why
    const Fault* fault = nullptr;             // fault
    StopClass stop = StopClass::kCut;         // fault
    bool inputs_ok = false;                   // acknowledge
  };
  // a handler's answer: the next mode (the current one: no transition) and the transition's event
  struct Next {
    ServoMode mode;
    EventReason reason = EventReason::kNone;
    const char* detail = "";
    int joint = -1, bus = -1;
    StopClass stop = StopClass::kNone;
  };
  using Handler = Next (*)(SafetyStateMachine&, const Occurrence&) noexcept;
  // one row of the table, per mode
  struct ModeRow {
    SafetyDecision::Torque torque;
    bool request_devices;             // entering the mode asks every device for device_request
    hal::DeviceState device_request;
    Handler on_bring_up, on_enable, on_disable, on_damp, on_acknowledge, on_stop, on_fault,
        on_damping_timer;
  };

  // the current mode's handler in `column`; true when it moved to another mode
  bool Dispatch(Handler ModeRow::*column, const Occurrence& o) noexcept;
  void Transition(ServoMode to, EventReason why, int joint, int bus, const char* detail,
                  StopClass stop = StopClass::kNone) noexcept;
  void Push(const SafetyEvent& e) noexcept;

  SafetyLimits limits_;
  double dt_;
  bool auto_enable_;
  double stop_timeout_s_;
  ServoMode mode_ = ServoMode::kInit;
  ServoMode damping_next_ = ServoMode::kFault;
  ServoMode decided_mode_ = ServoMode::kInit;  // the mode of the last Decide
  std::uint64_t cycle_ = 0;
  std::int64_t now_ns_ = 0;
  std::uint64_t cycles_in_mode_ = 0;
  std::uint64_t stop_cycle_ = 0;
  std::uint64_t ack_deadline_cycle_ = 0;
  std::uint32_t latched_ = 0;  // bit per EventReason reported since the last acknowledgement
  bool stop_ = false;
  bool ack_pending_ = false;
  bool hold_damping_ = false;
  bool ever_active_ = false;
  bool fault_sit_down_ = false;
  bool damping_cut_ = false;
  StopClass fault_stop_ = StopClass::kNone;
  EventReason fault_reason_ = EventReason::kNone;  // the fault that began fault_stop_
  std::array<SafetyEvent, kEventCapacity> ring_{};
  std::size_t head_ = 0, size_ = 0;
  std::uint64_t events_ = 0, dropped_ = 0;
};

}  // namespace hyq::servo
