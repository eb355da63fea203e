// The daemon's safety logic (docs/servo.md, "Safety"): plausibility checks on every cycle's
// inputs and outputs, and the mode state machine
//
//   INIT ──bring-up──► STANDBY ──enable──► ACTIVE ──disable──► STANDBY
//                        │  ▲                │ fault / damp / stop
//                  fault │  │ acknowledge    ▼
//                        ▼  │             DAMPING ──after damping_duration──► FAULT (fault)
//                       FAULT ◄──────────────┘                              ► STANDBY (damp)
//                                                                           ► STOPPED (stop)
//
// STANDBY: devices in OP, 0 N·m. ACTIVE: the controller's torque. DAMPING: τ = −D q̇ on the joints
// whose inputs are valid, 0 N·m on the others. FAULT: 0 N·m and the devices asked to SAFE-OP
// (outputs disabled) until an acknowledgement with the faults gone. Every transition, and every
// new fault while already safe, is a SafetyEvent with a reason (fixed ring, drained by the loop).
//
// Nothing here allocates, locks or throws after construction.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

#include "hal/hal.h"
#include "servo/servo_config.h"
#include "servo/telemetry_types.h"

namespace hyq::servo {

/// One problem found by a check: what, where, and a short human-readable detail.
struct Fault {
  EventReason reason = EventReason::kNone;
  std::int16_t joint = -1;
  std::int16_t bus = -1;
  std::array<char, 96> detail{};
  explicit operator bool() const noexcept { return reason != EventReason::kNone; }
};

/// Formats a Fault's detail (printf-style, truncated to fit). Never allocates.
Fault MakeFault(EventReason reason, int joint, int bus, const char* fmt, ...) noexcept
    __attribute__((format(printf, 4, 5)));

/// Plausibility of the process image and the buses, cycle by cycle.
class InputChecker {
 public:
  InputChecker(const SafetyLimits& limits, const hal::HalConfig& hal);

  /// Checks the inputs of the Read that just happened; the first fault found (none: reason
  /// kNone). `expect_op`: the devices should be in OP (after bring-up, outside FAULT).
  Fault Check(const hal::Hal& hal, hal::HalStatus read_status, bool expect_op) noexcept;

  /// Forget the previous positions and counter values (after a fault is acknowledged).
  void Reset(const hal::Hal& hal) noexcept;

 private:
  SafetyLimits limits_;
  std::array<double, hal::kNumJoints> q_min_{}, q_max_{};
  std::array<double, hal::kNumJoints> last_q_{};
  std::array<bool, hal::kNumJoints> have_last_{};
  std::array<std::uint64_t, hal::kMaxBuses> malformed_{}, bus_off_{}, error_frames_{};
};

class SafetyStateMachine {
 public:
  static constexpr std::size_t kEventCapacity = 64;

  explicit SafetyStateMachine(const SafetyLimits& limits, double dt) : limits_(limits), dt_(dt) {}

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
  /// Controlled stop: ACTIVE → DAMPING → STOPPED, anything else → STOPPED.
  void Stop() noexcept;
  /// A fault: ACTIVE → DAMPING, STANDBY → FAULT; while already safe, only an event (once per
  /// reason until acknowledged).
  void Report(const Fault& f) noexcept;
  /// Records an event without a transition (applied commands, refused commands).
  void Note(EventReason reason, const char* detail) noexcept;

  /// Events not yet taken by the loop, oldest first; Take() removes one.
  bool Take(SafetyEvent* e) noexcept;
  std::uint64_t events() const noexcept { return events_; }
  std::uint64_t events_dropped() const noexcept { return dropped_; }
  /// Whether the current DAMPING ends in FAULT (a fault caused it) rather than STANDBY/STOPPED.
  bool damping_for_fault() const noexcept { return damping_next_ == ServoMode::kFault; }
  bool stop_requested() const noexcept { return stop_; }

 private:
  void Transition(ServoMode to, EventReason why, int joint, int bus, const char* detail) noexcept;
  void Push(const SafetyEvent& e) noexcept;

  SafetyLimits limits_;
  double dt_;
  ServoMode mode_ = ServoMode::kInit;
  ServoMode damping_next_ = ServoMode::kFault;
  std::uint64_t cycle_ = 0;
  std::int64_t now_ns_ = 0;
  std::uint64_t cycles_in_mode_ = 0;
  std::uint32_t latched_ = 0;  // bit per EventReason reported since the last acknowledgement
  bool stop_ = false;
  std::array<SafetyEvent, kEventCapacity> ring_{};
  std::size_t head_ = 0, size_ = 0;
  std::uint64_t events_ = 0, dropped_ = 0;
};

}  // namespace hyq::servo
