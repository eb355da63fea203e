// The hardware abstraction: one Bus context per CAN bus (no globals) and the Hal that owns the
// process image of all of them (hal/process_image.h, docs/hal.md).
//
// One cycle, SYNC-driven (CANopen synchronous PDOs):
//   Read(now):  drain RX -> decode heartbeats, EMCYs, TPDOs -> working-counter check (a TPDO must
//               answer the SYNC sent by the previous Write: expected vs received per device and in
//               total) -> state machines -> process image inputs, calibrated, flagged per joint.
//   ...         the controller reads image().joints / imu and writes image().commands
//   Write(now): encode outputs (RPDO per actuator: set-point in OP, 0 N·m disabled in SAFE-OP) ->
//               queued NMT commands, RPDOs, then SYNC -> one batch Send per bus.
// Read and Write are noexcept, never allocate, never block, return a HalStatus and count faults.
// A Read without a Write since the previous Read expects nothing (no SYNC was sent).
// Not thread-safe: call everything (including RequestState / AcknowledgeFaults) from the thread
// that runs the cycle.
// Construction validates the configuration (including the bus load) and throws ConfigError.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "hal/can_channel.h"
#include "hal/config_error.h"
#include "hal/device_state_machine.h"
#include "hal/hal_config.h"
#include "hal/process_image.h"
#include "hal/protocol.h"

namespace hyq::hal {

enum class [[nodiscard]] HalStatus : std::uint8_t {
  kOk,
  kWorkingCounter,  // some expected inputs missing, late or duplicated (see the flags per joint)
  kBadCommand,      // a non-finite torque command was replaced by 0 N·m (counted)
  kTxFailed,        // the channel did not take every frame (kWouldBlock / kBadFrame / kIoError)
  kBusOff,          // the channel reports bus-off
};
const char* ToString(HalStatus s) noexcept;

struct BusCounters {
  std::uint64_t cycles = 0;
  std::uint64_t rx_frames = 0;
  std::uint64_t tx_frames = 0;
  std::uint64_t wkc_faults = 0;      // cycles whose working counter did not match
  std::uint64_t missing = 0;         // device inputs expected but not received
  std::uint64_t held = 0;            // of those, held (within timing.max_held_cycles in a row)
  std::uint64_t late = 0;            // TPDOs answering an older SYNC (not used)
  std::uint64_t duplicate = 0;
  std::uint64_t malformed = 0;       // frames with a device's id that failed to decode
  std::uint64_t driver_dropped = 0;  // input the channel dropped as malformed (CanCounters::bad_frames)
  std::uint64_t unknown = 0;         // frames from ids no configured device owns
  /// SYNC, NMT or RPDO frames received: the HAL is the only sender of those on its buses (the
  /// drivers drop the HAL's own echoes), so each is a second master or a spoofer
  std::uint64_t foreign_master = 0;
  std::uint32_t last_foreign_id = 0; // COB-ID of the last one
  std::uint64_t error_frames = 0;    // error frames passed up by the driver
  std::uint64_t emcy = 0;
  std::uint64_t bad_commands = 0;    // non-finite torque commands replaced by 0
  std::uint64_t saturated = 0;       // commands clamped to the torque limit
  std::uint64_t tx_failed = 0;       // frames the channel did not take
  std::uint64_t tx_queue_overflow = 0;
  std::uint64_t rx_backlog = 0;      // cycles that left frames in the channel (RX budget hit)
  std::uint64_t rx_errors = 0;       // Receive returned something other than kOk
  std::uint64_t bus_off = 0;         // cycles in which the channel reported bus-off
  std::uint64_t last_fault_cycle = 0;
  std::uint8_t last_fault_node = 0;
  std::uint16_t last_emcy_code = 0;
  std::uint8_t last_emcy_node = 0;
};

class Bus {
 public:
  static constexpr std::size_t kRxBatch = 64;
  static constexpr std::size_t kMaxRxPerCycle = 256;

  /// `calibration` and `channel` are not owned and must outlive the Bus.
  Bus(BusConfig config, const TimingConfig& timing,
      const std::array<JointCalibration, kNumJoints>* calibration, CanChannel* channel);

  HalStatus Read(std::int64_t now_ns, std::uint64_t cycle, ProcessImage* image) noexcept;
  HalStatus Write(std::int64_t now_ns, const ProcessImage& image) noexcept;

  void RequestState(DeviceState target, std::int64_t now_ns) noexcept;
  /// The board of `joint` (if on this bus) to SAFE-OP: its outputs off (Hal::ReleaseJoint).
  void ReleaseJoint(int joint) noexcept;
  void AcknowledgeFaults(std::int64_t now_ns) noexcept;
  bool AllIn(DeviceState s) const noexcept;

  const BusConfig& config() const noexcept { return config_; }
  std::span<const DeviceRuntime> devices() const noexcept { return devices_; }
  const BusCounters& counters() const noexcept { return counters_; }
  WorkingCounter wkc() const noexcept { return wkc_; }
  std::uint8_t sync_counter() const noexcept { return sync_counter_; }
  CanChannel& channel() noexcept { return *channel_; }
  const CanChannel& channel() const noexcept { return *channel_; }

 private:
  void HandleFrame(const CanFrame& f, StateMachineContext& ctx) noexcept;
  void Publish(const DeviceRuntime& d, ProcessImage* image) noexcept;
  void Flush() noexcept;
  StateMachineContext Context(std::int64_t now_ns) noexcept;

  BusConfig config_;
  StateMachineTiming timing_;
  double period_s_;  // the SYNC period: a held position moves on by the last velocity per period
  const std::array<JointCalibration, kNumJoints>* calibration_;
  CanChannel* channel_;
  std::vector<DeviceRuntime> devices_;
  std::array<std::int8_t, kMaxNodeId + 1> node_to_device_{};
  std::array<CanFrame, kRxBatch> rx_{};
  std::vector<CanFrame> tx_storage_;
  FrameQueue tx_;
  std::uint8_t sync_counter_ = 0;  // of the last SYNC sent; 0 = none yet
  std::int64_t heartbeat_period_ns_ = 0;  // of the master's heartbeat
  std::int64_t next_heartbeat_ns_ = -1;   // -1: send one with the next Write
  std::uint64_t cycle_ = 0;
  bool saw_bus_off_ = false;
  bool sync_since_read_ = false;   // a SYNC went out since the last Read: inputs are expected
  WorkingCounter wkc_;
  BusCounters counters_;
};

enum class BringUpStatus : std::uint8_t { kInProgress, kComplete, kTimedOut };

class Hal {
 public:
  /// channels[i] carries config.buses[i]; not owned, must outlive the Hal. Validates the
  /// configuration (ValidateHalConfig, including the bus-load limit) and throws ConfigError.
  Hal(HalConfig config, std::span<CanChannel* const> channels);

  HalStatus Read(std::int64_t now_ns) noexcept;
  HalStatus Write(std::int64_t now_ns) noexcept;

  ProcessImage& image() noexcept { return image_; }
  const ProcessImage& image() const noexcept { return image_; }

  /// Every device's target; also starts the bring-up clock when going up.
  void RequestState(DeviceState target, std::int64_t now_ns) noexcept;
  /// Takes the board of `joint` to SAFE-OP and keeps it there until the next RequestState: its
  /// outputs off (0 N·m, not enabled), so that a hydraulic board closes its valve and locks the
  /// joint (a lost joint's board that is still in OP would otherwise follow a 0 N·m set-point
  /// and let it go limp). Idempotent, for the cycle.
  void ReleaseJoint(int joint) noexcept;
  /// Clears latched errors so devices in SAFE-OP may go back to OP.
  void AcknowledgeFaults(std::int64_t now_ns) noexcept;
  bool AllIn(DeviceState s) const noexcept;
  /// Whether every device reached the last requested target within timing.bringup_timeout_s.
  BringUpStatus PollBringUp(std::int64_t now_ns) const noexcept;
  /// Who is not in the requested state, in which state, with the last error and heartbeat age
  /// (allocates; for logs and exceptions, not for the cycle).
  std::string BringUpReport(std::int64_t now_ns) const;

  std::size_t num_buses() const noexcept { return buses_.size(); }
  Bus& bus(std::size_t i) { return *buses_.at(i); }
  const Bus& bus(std::size_t i) const { return *buses_.at(i); }
  const HalConfig& config() const noexcept { return config_; }

 private:
  HalConfig config_;
  std::vector<std::unique_ptr<Bus>> buses_;
  ProcessImage image_;
  DeviceState target_ = DeviceState::kInit;
  std::int64_t bringup_start_ns_ = 0;
};

/// Runs cycles (Read, Write, then `next_cycle`, which waits for or simulates the next period and
/// returns the new time) until every device is in `target`; throws ConfigError with
/// Hal::BringUpReport when timing.bringup_timeout_s passes first. Configuration-time only.
void RunBringUp(Hal& hal, DeviceState target, std::int64_t now_ns,
                const std::function<std::int64_t()>& next_cycle);

}  // namespace hyq::hal
