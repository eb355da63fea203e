// The servo's shared vocabulary: the capacities every module sizes its arrays by, the safety
// modes and event reasons, the controller kinds and the operator command. Plain fixed-size
// values: they cross threads through lock-free rings (hal/spsc_ring.h) and are turned
// into LCM messages only on the telemetry thread.
//
// Units are in the names: _rad, _rad_s, _Nm, _N, _m, _m_s, _ns, _us. Joint order lf, rf, lh, rh x
// haa, hfe, kfe; feet lf, rf, lh, rh.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include "dynamics/model.h"
#include "hal/config_key.h"
#include "hal/hal_config.h"

namespace hyq::servo {

using dynamics::VectorJ;
using dynamics::VectorQ;
using dynamics::VectorV;

// The HAL and the dynamics each count HyQ's joints and feet; the servo joins them, so they must
// agree.
inline constexpr int kNumJoints = hal::kNumJoints;
inline constexpr int kNumFeet = dynamics::kNumFeet;
inline constexpr int kMaxBuses = hal::kMaxBuses;
static_assert(hal::kNumJoints == dynamics::kNumJoints, "hal and dynamics disagree on HyQ's joints");
static_assert(hal::kNumLegs == dynamics::kNumFeet, "one foot per leg");
/// Devices in the telemetry's health message (12 joint boards and the IMU, with room).
inline constexpr int kMaxDevices = 16;
static_assert(kMaxDevices >= kNumJoints + 1, "every joint board and the IMU");
/// Characters of an event's detail, NUL included.
inline constexpr std::size_t kEventDetailSize = 96;

/// The daemon's safety state (servo/runtime/safety_state_machine.h).
enum class ServoMode : std::uint8_t {
  kInit,     // bring-up: devices not yet in OP
  kStandby,  // devices in OP, outputs disabled, zero torque
  kActive,   // the controller's torques are applied
  kDamping,  // τ = −D q̇ for a while, then zero torque (controlled stop)
  kFault,    // zero torque, outputs disabled, until the faults are acknowledged
  kStopped,  // shut down: devices back to PRE-OP
};
const char* ToString(ServoMode m) noexcept;

/// Why the mode changed (or a command was refused): one code per cause.
enum class EventReason : std::uint16_t {
  kNone,
  kBringUpComplete,       // all devices in OP
  kEnableCommand,         // operator enable (command channel or auto_enable)
  kDisableCommand,        // operator disable
  kDampingCommand,
  kAcknowledge,           // faults acknowledged
  kStopRequest,           // SIGINT / SIGTERM / duration over
  kDampingDone,
  kDeviceFault,           // a device reports a fault or left OP
  kInputMissing,          // a joint/IMU input missing or stale for too many cycles
  kBusOff,
  kCorruptFrames,         // malformed frames on a bus
  kNonFiniteInput,        // NaN / Inf in a sensor value
  kOutOfRange,            // position outside the joint range (+ margin), torque/rate implausible
  kInputJump,             // position jump between cycles larger than physically possible
  kControllerFailure,     // the controller fell back to "safety" or produced non-finite torque
  kDeadlineMiss,          // N consecutive deadline misses
  kEstimatorFailure,      // non-finite or implausible base state
  kCommandRejected,       // a command on the command channel was refused (detail says why)
  kCommandApplied,        // a command changed a setting (detail says which)
  kForeignMaster,         // a SYNC, NMT or RPDO frame the daemon did not send (a second master)
  kCount,                 // not a reason: the number of reasons
};
inline constexpr std::size_t kNumEventReasons = static_cast<std::size_t>(EventReason::kCount);
static_assert(kNumEventReasons <= 32, "SafetyStateMachine latches one bit per reason");
const char* ToString(EventReason r) noexcept;

/// How a fault stops the robot (servo/runtime/stop_class.h), after IEC 60204-1's stop categories:
/// what the fault leaves the daemon decides it.
enum class StopClass : std::uint8_t {
  kNone,        // no stop (not a fault)
  kControlled,  // control intact: the sit-down with the full controller, then damping (cat. 1)
  kDegraded,    // one device lost: the sit-down without it, then damping (cat. 1)
  kCut,         // a leg, two devices or the estimate lost: damping at once (cat. 0)
};
inline constexpr int kNumStopClasses = 4;
/// "none", "controlled", "degraded", "cut".
const char* ToString(StopClass c) noexcept;

/// The inputs a fault's stop must do without (servo/runtime/stop_class.h), latched until the
/// faults are acknowledged: the estimator, the motion sequencer and the controller leave them out.
struct LostInputs {
  std::array<bool, kNumJoints> joint{};
  bool imu = false;
  bool control = false;  // the estimate or the controller's torque
  bool any() const noexcept {
    for (bool j : joint)
      if (j) return true;
    return imu || control;
  }
  /// A joint of leg `l` (0..3: lf rf lh rh) is lost.
  bool leg(int l) const noexcept {
    for (int k = 0; k < hal::kJointsPerLeg; ++k)
      if (joint[static_cast<std::size_t>(hal::kJointsPerLeg * l + k)]) return true;
    return false;
  }
  int legs() const noexcept {  // legs with a lost joint
    int n = 0;
    for (int l = 0; l < hal::kNumLegs; ++l) n += leg(l) ? 1 : 0;
    return n;
  }
  void Clear() noexcept { *this = LostInputs{}; }
};

struct SafetyEvent {
  std::uint64_t cycle = 0;
  std::int64_t time_ns = 0;   // CLOCK_MONOTONIC (or virtual time in lock-step)
  ServoMode from = ServoMode::kInit;
  ServoMode to = ServoMode::kInit;
  EventReason reason = EventReason::kNone;
  std::int16_t joint = -1;    // the joint concerned, −1 when none
  std::int16_t bus = -1;      // the bus concerned, −1 when none
  StopClass stop = StopClass::kNone;  // the stop this fault began or joined (faults only)
  std::array<char, kEventDetailSize> detail{};  // NUL-terminated human-readable detail
};

/// The joint controllers (servo/control/controller.h).
enum class ControllerKind : std::uint8_t { kPid, kNoSlipId, kStage1Id, kTwoStageId, kPdGravity };
inline constexpr int kNumControllerKinds = 5;
const char* ToString(ControllerKind k) noexcept;
/// "pid", "noslip", "stage1", "two_stage", "pd_gravity".
std::optional<ControllerKind> ParseControllerKind(std::string_view name) noexcept;
/// The same names with their kinds, as a configuration key takes them.
std::vector<hal::Choice<ControllerKind>> ControllerKindChoices();

// Upper bounds on the configured gains: beyond them the discrete loop at 1 kHz on HyQ's lightest
// joint (HAA of a leg in the air, ≈ 0.3 kg·m² reflected) would not be stable, or the numbers are
// typing errors (docs/servo.md, "Gains").
inline constexpr double kMaxKpTau = 5000.0;  // N·m/rad
inline constexpr double kMaxKdTau = 200.0;   // N·m·s/rad
inline constexpr double kMaxKiTau = 5000.0;  // N·m/(rad·s)

/// An operator command, validated by the command channel before it reaches the servo thread.
struct ServoCommand {
  enum class Kind : std::uint8_t {
    kEnable,       // STANDBY -> ACTIVE (the only way into ACTIVE besides auto_enable)
    kDisable,      // ACTIVE -> STANDBY (zero torque)
    kDamp,         // -> DAMPING
    kAcknowledge,  // FAULT -> STANDBY once the faults are gone
    kSetMu,        // friction per foot used by the controller
    kSetController,
    kSetGains,     // feedback gains (scaled copies of the configured ones)
    kSetVelocity,  // the trot's commanded base velocity (vx, vy, wz)
    kRejected,     // a command that failed validation (the servo thread goes to its safe state
                   // when safety.damp_on_bad_command; the channel published the reason)
  };
  Kind kind = Kind::kDisable;
  std::array<double, kNumFeet> mu{};        // kSetMu
  ControllerKind controller = ControllerKind::kPid;  // kSetController
  double kp_scale = 1.0, kd_scale = 1.0;          // kSetGains: multipliers of the configured gains
  std::array<double, 3> velocity{};  // kSetVelocity: vx m/s, vy m/s (heading frame), wz rad/s
  std::uint64_t sequence = 0;                     // the sender's sequence number (echoed in events)
};

/// "enable", "disable", "damp", "ack", "mu", "controller", "gains", "velocity", "rejected".
const char* ToString(ServoCommand::Kind k) noexcept;

}  // namespace hyq::servo
