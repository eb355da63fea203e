// A device emulator: HyQ's 12 actuator boards and the IMU answering the HAL's protocol on any
// CanChannel (a LoopbackBus endpoint in tests, SocketCAN / UDP multicast in the emulator tool),
// with fault injection. The hardware-in-the-loop plant (MuJoCo) sets the joint states, forces and
// IMU readings the boards report and reads the torque set-points they received.
//
// Device behaviour (docs/can_protocol.md): power-on and NMT reset -> boot-up message, NMT
// PRE-OPERATIONAL; heartbeat every timing.heartbeat_period_s; NMT start -> OPERATIONAL: one TPDO1
// per SYNC, echoing the SYNC counter; RPDO1 with control_bit::kEnable applies the torque set-point
// (status_bit::kEnabled), without it the outputs are safe (0 N·m); an RPDO watchdog disables the
// outputs after kRpdoWatchdogSyncs SYNCs without set-points (EMCY 0x8250); and on the board's own
// timer, whether SYNCs come or not, a board in OPERATIONAL without a SYNC, or with outputs on
// without a set-point, for timing.device_setpoint_timeout_s sets 0 N·m, sends EMCY 0x8250 and
// drops to PRE-OPERATIONAL (a dead master leaves no torque on the joints). A reset of the board
// itself (a power glitch, its watchdog: ResetJointBoard, ResetImu) turns its outputs off at once,
// silences it for its boot time and then boots it as after power-on.
//
// Poll() never allocates (fixed queues sized at construction). Single-threaded.
#pragma once

#include <array>
#include <climits>
#include <cstdint>
#include <span>
#include <vector>

#include "hal/can_channel.h"
#include "hal/hal_config.h"
#include "hal/protocol.h"

namespace hyq::hal {

/// Faults one emulated device injects; set them between Poll calls.
struct DeviceFaults {
  std::uint32_t drop_next = 0;       // drop the next N TPDOs
  double drop_probability = 0.0;     // drop each TPDO with this probability (seeded RNG)
  std::uint32_t delay_syncs = 0;     // answer SYNC k only after SYNC k + delay arrives (late)
  std::uint32_t corrupt_next = 0;    // next N TPDOs malformed (wrong length, garbage payload)
  std::uint32_t duplicate_next = 0;  // next N TPDOs sent twice
  bool silent = false;               // send nothing at all and ignore everything received
  bool no_heartbeat = false;         // TPDOs yes, heartbeats no
  bool refuse_enable = false;        // never applies set-points (never reports kEnabled)
  /// A broken load cell / torque sensor (or IMU): the effort counts (IMU: every reading) are
  /// kInvalidSensorCounts, outside the 24-bit ADC's range, and the status word has
  /// status_bit::kSensorFault. (The HAL converts counts to doubles, so a board cannot send a NaN;
  /// this is what it sends instead.) Combine with SendJointEmcy(j, emcy::kSensor) for a board
  /// that also latches the fault.
  bool sensor_fault = false;
};

/// The reading a board with a broken sensor reports (INT32_MIN: no 24-bit ADC produces it).
inline constexpr std::int32_t kInvalidSensorCounts = INT32_MIN;

struct EmulatorCounters {
  std::uint64_t rx_frames = 0;
  std::uint64_t tx_frames = 0;
  std::uint64_t syncs = 0;
  std::uint64_t rpdos = 0;
  std::uint64_t malformed_rx = 0;   // frames addressed to an emulated device that failed to decode
  std::uint64_t dropped = 0;
  std::uint64_t delayed = 0;
  std::uint64_t corrupted = 0;
  std::uint64_t duplicated = 0;
  std::uint64_t tx_failed = 0;
  std::uint64_t bus_off_events = 0;
  std::uint64_t setpoint_timeouts = 0;  // boards that tripped on their own timer
  std::uint64_t master_heartbeats = 0;  // the master's heartbeats received
  std::uint64_t heartbeat_trips = 0;    // boards that tripped because the master's heartbeat stopped
  std::uint64_t superseded_syncs = 0;   // SYNCs left unanswered: a newer one was already waiting
                                        // (only with SetAnswerNewestSyncOnly)
  std::uint64_t resets = 0;             // devices reset (ResetJointBoard, ResetImu)
};

class Emulator {
 public:
  static constexpr std::uint32_t kRpdoWatchdogSyncs = 3;

  /// channels[i] carries config.buses[i] (the device side); not owned, must outlive the Emulator.
  /// Throws ConfigError when the sizes differ or the configuration is invalid (ValidateHalConfig).
  Emulator(const HalConfig& config, std::span<CanChannel* const> channels,
           std::uint64_t seed = 1);

  /// Drains every channel and answers (NMT, SYNC, RPDO), sends due heartbeats and queued EMCYs.
  void Poll(std::int64_t now_ns) noexcept;

  /// When on, a Poll that finds several SYNCs waiting on a bus answers only the newest: the
  /// older ones still count (the RPDO watchdog, delayed frames) but get no TPDOs, which the
  /// master would discard as stale anyway. Real boards answer within microseconds and are never
  /// behind; an emulator on a shared host is, after a stall, and answering every missed SYNC
  /// then only puts it further behind. Off by default (every SYNC answered, as on the wire).
  void SetAnswerNewestSyncOnly(bool on) noexcept { newest_sync_only_ = on; }

  // --- the plant's side -------------------------------------------------------------------
  /// What joint `joint` reports: angle, velocity and joint torque (the board's sensor reports the
  /// matching cylinder force / torque-sensor counts through the inverse calibration).
  void SetJointState(int joint, double position_rad, double velocity_rad_s,
                     double torque_Nm) noexcept;
  /// The same with the sensor's own quantity: the cylinder force in N (HFE/KFE, + = pushing) or
  /// the HAA torque in N·m, for plants that model the actuators.
  void SetJointSensor(int joint, double position_rad, double velocity_rad_s,
                      double sensor_value) noexcept;
  void SetImu(const std::array<double, 3>& gyro_rad_s,
              const std::array<double, 3>& accel_m_s2) noexcept;
  /// The torque set-point the board applies now (0 when its outputs are disabled).
  double torque_setpoint_Nm(int joint) const noexcept;
  bool outputs_enabled(int joint) const noexcept;
  NmtState nmt_state(int joint) const noexcept;
  std::uint64_t rpdos_received(int joint) const noexcept;
  /// When the board tripped on its own set-point timer (−1: never) and how long after its last
  /// SYNC or set-point (the fault reaction time as the board saw it), ns.
  std::int64_t setpoint_trip_ns(int joint) const noexcept;
  std::int64_t setpoint_trip_delay_ns(int joint) const noexcept;

  // --- fault injection ----------------------------------------------------------------------
  DeviceFaults& joint_faults(int joint) noexcept;
  DeviceFaults& imu_faults() noexcept;
  /// The board sends an EMCY with `code` at the next Poll and latches a fault (status_bit::kFault,
  /// outputs off) until a control word with kFaultReset; code emcy::kNoError only reports.
  void SendJointEmcy(int joint, std::uint16_t code) noexcept;
  /// Bus-off on bus `bus` as the devices see it: they stop transmitting and ignore the bus until
  /// SetBusOff(bus, false), after which each sends EMCY 0x8140 (recovered from bus-off).
  void SetBusOff(int bus, bool off) noexcept;
  bool bus_off(int bus) const noexcept;
  /// Power-cycles every device on `bus` (boot-up, PRE-OPERATIONAL, outputs off).
  void ResetBus(int bus) noexcept;
  /// A reset of joint's board (a power glitch or its watchdog): its outputs off at once (0 N·m,
  /// not enabled); silent, sending nothing and hearing nothing (NMT, SYNC, RPDO), until boot_ns
  /// after the last Poll's time; then, at the first Poll from then on, its boot-up message and
  /// PRE-OPERATIONAL as after power-on: no set-point, not enabled, no fault or watchdog latched,
  /// no EMCY owed, answering NMT again. The injected DeviceFaults stay (they are the hardware's:
  /// a broken load cell is broken after a reset too), and so do the plant's values.
  void ResetJointBoard(int joint, std::int64_t boot_ns) noexcept;
  /// The same for the IMU.
  void ResetImu(std::int64_t boot_ns) noexcept;
  /// Whether joint's board is silent after a reset, still booting.
  bool booting(int joint) const noexcept;

  const EmulatorCounters& counters(int bus) const noexcept;

 private:
  struct Device {
    DeviceKind kind = DeviceKind::kActuator;
    std::uint8_t node = 0;
    int joint = -1;
    int bus = 0;
    NmtState nmt = NmtState::kPreOperational;
    bool boot_pending = true;     // send the boot-up message at the next Poll
    std::int64_t boot_at_ns = -1; // >= 0: reset, silent until this Poll time, then boots
    bool enabled = false;
    bool fault = false;
    bool watchdog = false;
    bool rpdo_since_sync = false;
    std::uint32_t rpdo_missed = 0;
    std::uint16_t pending_emcy = 0;
    bool emcy_pending = false;
    std::int32_t torque_mNm = 0;
    std::uint64_t rpdos = 0;
    std::int64_t next_heartbeat_ns = 0;
    std::int64_t last_setpoint_ns = -1;  // last RPDO
    std::int64_t op_entered_ns = -1;     // NMT start
    std::int64_t trip_ns = -1, trip_delay_ns = 0;
    // the plant's values
    std::int32_t position_counts = 0, velocity_counts_s = 0, effort_counts = 0;
    std::array<std::int32_t, 3> gyro_urad_s{}, accel_um_s2{};
    DeviceFaults faults;
  };
  struct Delayed {
    CanFrame frame;
    std::uint32_t syncs_left = 0;
  };
  struct BusState {
    CanChannel* channel = nullptr;
    std::vector<int> devices;         // indices into devices_
    std::array<std::int8_t, kMaxNodeId + 1> node_to_device{};
    std::vector<CanFrame> rx;         // fixed capacity: one Poll's frames
    std::vector<CanFrame> tx;         // fixed capacity
    std::size_t tx_size = 0;
    std::vector<Delayed> delayed;     // fixed capacity
    std::size_t delayed_size = 0;
    bool off = false;
    bool recovered = false;
    std::int64_t last_sync_ns = -1;
    std::int64_t last_master_heartbeat_ns = -1;  // -1: none yet (the consumer is not active)
    EmulatorCounters counters;
  };

  // joint's board, nullptr when `joint` is out of range or has none
  Device* JointDevice(int joint) noexcept;
  const Device* JointDevice(int joint) const noexcept;
  // what joint's board reports: (q, q̇) as encoder counts and effort_counts(its calibration)
  template <class EffortCounts>
  void SetJointCounts(int joint, double position_rad, double velocity_rad_s,
                      const EffortCounts& effort_counts) noexcept;
  void HandleFrame(BusState& b, const CanFrame& f, bool answer_sync) noexcept;
  void OnSync(BusState& b, std::uint8_t counter, bool answer) noexcept;
  void Answer(BusState& b, Device& d, std::uint8_t counter) noexcept;
  void Nmt(Device& d, NmtCommand cmd) noexcept;
  void Reset(Device& d, std::int64_t boot_ns) noexcept;
  void CheckSetpointTimer(BusState& b, Device& d, std::int64_t now_ns) noexcept;
  void CheckMasterHeartbeat(BusState& b, Device& d, std::int64_t now_ns) noexcept;
  void Queue(BusState& b, const CanFrame& f) noexcept;
  void Flush(BusState& b) noexcept;
  double Uniform() noexcept;

  HalConfig config_;
  std::int64_t heartbeat_period_ns_;
  std::int64_t setpoint_timeout_ns_;
  std::int64_t master_heartbeat_timeout_ns_;
  std::vector<Device> devices_;
  std::vector<BusState> buses_;
  std::array<int, kNumJoints> joint_to_device_{};
  int imu_device_ = -1;
  Device dummy_;  // fault target for an absent IMU / out-of-range joint
  std::uint64_t rng_;
  std::int64_t now_ns_ = 0;
  bool newest_sync_only_ = false;
};

}  // namespace hyq::hal
