// What the servo thread hands to the telemetry thread (one TelemetrySnapshot per cycle, events as
// they happen) and what the command channel hands back (ServoCommand). Plain fixed-size values:
// they cross threads through lock-free single-producer/single-consumer rings (servo/spsc_ring.h)
// and are turned into LCM messages (lcmtypes/) only on the telemetry thread.
//
// Units are in the names: _rad, _rad_s, _Nm, _N, _m, _m_s, _ns, _us. Joint order lf, rf, lh, rh x
// haa, hfe, kfe; feet lf, rf, lh, rh.
#pragma once

#include <array>
#include <cstdint>

namespace hyq::servo {

inline constexpr int kTelemetryJoints = 12;
inline constexpr int kTelemetryFeet = 4;
inline constexpr int kTelemetryBuses = 8;
inline constexpr int kTelemetryDevices = 16;

/// The daemon's safety state (servo/safety.h).
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
};
const char* ToString(EventReason r) noexcept;

struct SafetyEvent {
  std::uint64_t cycle = 0;
  std::int64_t time_ns = 0;   // CLOCK_MONOTONIC (or virtual time in lock-step)
  ServoMode from = ServoMode::kInit;
  ServoMode to = ServoMode::kInit;
  EventReason reason = EventReason::kNone;
  std::int16_t joint = -1;    // the joint concerned, −1 when none
  std::int16_t bus = -1;      // the bus concerned, −1 when none
  std::array<char, 96> detail{};  // NUL-terminated human-readable detail
};

/// Timings of one cycle, ns (stages in order).
struct CycleTiming {
  std::int64_t wakeup_latency_ns = 0;  // actual wake-up − scheduled wake-up
  std::int64_t read_ns = 0;            // HAL read (drain RX, decode, working counter)
  std::int64_t estimate_ns = 0;
  std::int64_t reference_ns = 0;
  std::int64_t control_ns = 0;         // dynamics + controller
  std::int64_t safety_ns = 0;
  std::int64_t write_ns = 0;           // HAL write (RPDOs + SYNC)
  std::int64_t total_ns = 0;           // read start .. write end
};

struct BusHealth {
  std::uint64_t rx_frames = 0, tx_frames = 0;
  std::uint64_t wkc_faults = 0, missing = 0, malformed = 0, error_frames = 0, emcy = 0;
  std::uint64_t bus_off = 0, tx_failed = 0;
  std::uint32_t wkc_expected = 0, wkc_received = 0;
};

/// Everything the telemetry publishes about one cycle.
struct TelemetrySnapshot {
  std::uint64_t cycle = 0;
  std::int64_t time_ns = 0;             // cycle start (monotonic or virtual)
  double reference_time_s = 0.0;        // time along the reference (0 until ACTIVE)
  ServoMode mode = ServoMode::kInit;
  std::uint8_t controller = 0;          // servo::ControllerKind

  // joints
  std::array<double, kTelemetryJoints> q_rad{}, qd_rad_s{}, tau_measured_Nm{};
  std::array<double, kTelemetryJoints> q_ref_rad{}, qd_ref_rad_s{}, tau_command_Nm{};
  std::array<std::uint8_t, kTelemetryJoints> input_status{};  // hal::InputStatus

  // estimated base state (world frame; orientation as quaternion w, x, y, z)
  std::array<double, 3> base_position_m{}, base_velocity_m_s{}, base_angular_velocity_rad_s{};
  std::array<double, 4> base_orientation_wxyz{1.0, 0.0, 0.0, 0.0};

  // contacts and the inverse dynamics
  std::array<std::uint8_t, kTelemetryFeet> stance_reference{}, stance_estimated{};
  std::array<double, kTelemetryFeet> mu{};
  std::array<std::array<double, 3>, kTelemetryFeet> contact_force_N{};  // impulse / dt, world
  std::uint8_t stage1_status = 0, stage2_status = 0, fallback = 0;  // qp::Status, servo::Fallback
  std::int32_t stage1_iterations = 0, stage2_iterations = 0;
  double stage1_solve_us = 0.0, stage2_solve_us = 0.0;
  double tracking_error_rad = 0.0;      // ‖q_ref − q‖

  // timing and deadline
  CycleTiming timing;
  std::uint64_t deadline_misses = 0;    // cycles whose work overran the budget
  std::uint32_t consecutive_misses = 0;
  std::uint64_t skipped_cycles = 0;     // periods skipped to get back on schedule

  // device and bus health
  std::uint8_t num_buses = 0;
  std::array<BusHealth, kTelemetryBuses> buses{};
  std::uint8_t num_devices = 0;
  std::array<std::uint8_t, kTelemetryDevices> device_state{};  // hal::DeviceState
  std::uint8_t hal_read_status = 0, hal_write_status = 0;     // hal::HalStatus
  std::uint64_t events = 0;             // safety events so far
};

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
    kRejected,     // a command that failed validation (the servo thread goes to its safe state
                   // when safety.damp_on_bad_command; the channel published the reason)
  };
  Kind kind = Kind::kDisable;
  std::array<double, kTelemetryFeet> mu{};        // kSetMu
  std::uint8_t controller = 0;                    // kSetController: servo::ControllerKind
  double kp_scale = 1.0, kd_scale = 1.0;          // kSetGains: multipliers of the configured gains
  std::uint64_t sequence = 0;                     // the sender's sequence number (echoed in events)
};

/// Where snapshots and events go and commands come from (the LCM telemetry thread's rings, or a
/// test double). Every call is made from the servo thread and must be wait-free.
class TelemetrySink {
 public:
  virtual ~TelemetrySink() = default;
  virtual bool Push(const TelemetrySnapshot& s) noexcept = 0;
  virtual bool PushEvent(const SafetyEvent& e) noexcept = 0;
  virtual bool PopCommand(ServoCommand* c) noexcept = 0;
};

}  // namespace hyq::servo
