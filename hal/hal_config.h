// Plain configuration structs for the HAL (house style §1: hal declares them, config/ fills them
// from YAML, see config/hal_config_loader.h). Joint order everywhere: legs lf, rf, lh, rh, each
// haa, hfe, kfe; joint index = 3 * leg + {0, 1, 2}.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "hal/calibration.h"
#include "hal/config_key.h"

namespace hyq::hal {

inline constexpr int kNumLegs = 4;
inline constexpr int kJointsPerLeg = 3;
inline constexpr int kNumJoints = kNumLegs * kJointsPerLeg;
inline constexpr int kMaxBuses = 8;
inline constexpr int kMaxDevicesPerBus = 16;

/// "lf_haa_joint", ... for joint 0..11; "" outside.
std::string_view JointName(int joint) noexcept;
/// The index of a joint name, or -1.
int JointIndex(std::string_view name) noexcept;
/// The joint names with their indices, as a configuration key takes them.
std::vector<Choice<int>> JointChoices();

enum class DeviceKind : std::uint8_t { kActuator, kImu };

struct DeviceConfig {
  std::string name;                      // e.g. "lf_haa" or "imu"
  DeviceKind kind = DeviceKind::kActuator;
  std::uint8_t node_id = 1;              // CANopen node id 1..127, unique on its bus
  int joint = -1;                        // joint index for actuators, -1 for the IMU

  template <class A>
  void Serialize(A* a) {
    a->Visit(Key("name", &name).Required().Doc("the device's name, e.g. lf_haa"));
    a->Visit(Key("kind", &kind).Required()
                 .Choices({{"actuator", DeviceKind::kActuator}, {"imu", DeviceKind::kImu}})
                 .Doc("a joint's actuator board or the IMU"));
    a->Visit(Key("node_id", &node_id).Required().In(1, 127).Doc("CANopen node id, unique on its bus"));
    a->Visit(Key("joint", &joint).Required(kind == DeviceKind::kActuator).Choices(JointChoices())
                 .Elements("a joint name {lf,rf,lh,rh}_{haa,hfe,kfe}_joint")
                 .Check([this](const int& j) -> std::optional<Violation> {
                   if (kind == DeviceKind::kImu && j >= 0) return Violation{"no joint for an IMU"};
                   return std::nullopt;
                 })
                 .Doc("an actuator's joint; none for the IMU"));
  }
};

struct BusConfig {
  std::string name;                       // "lf", ...
  std::string interface;                  // "can0", "vcan0", "udp:239.74.163.2:43113", ...
  bool fd = true;                         // CAN FD with bit-rate switch
  std::uint32_t nominal_bitrate = 1'000'000;  // arbitration phase, bit/s
  std::uint32_t data_bitrate = 5'000'000;     // FD data phase, bit/s
  std::vector<DeviceConfig> devices;

  template <class A>
  void Serialize(A* a) {
    a->Visit(Key("name", &name).Required().Doc("the bus's name (lf, rf, ...)"));
    a->Visit(Key("interface", &interface).Required()
                 .Doc("socketcan:can0, vcan0, udp:GROUP:PORT, ... (docs/drivers.md)"));
    a->Visit(Key("fd", &fd).Required().Doc("CAN FD with bit-rate switch (the PDO layout needs it)"));
    a->Visit(Key("nominal_bitrate", &nominal_bitrate).Required().In(10'000, 1'000'000)
                 .Unit("bit/s").Doc("arbitration phase"));
    a->Visit(Key("data_bitrate", &data_bitrate).Required(fd).In(10'000, 12'000'000)
                 .Unit("bit/s").Doc("FD data phase (required with fd)"));
    a->Visit(Key("devices", &devices).Required().NonEmpty().Elements("devices")
                 .Doc("the bus's devices"));
  }
};

struct TimingConfig {
  double cycle_period_s = 0.001;       // SYNC period
  double state_timeout_s = 0.5;        // a requested state transition must finish within this
  double bringup_timeout_s = 3.0;      // all devices in the requested state within this
  double heartbeat_period_s = 0.1;     // producer heartbeat time of the boards
  double heartbeat_timeout_s = 0.35;   // consumer time: no heartbeat for this long = device lost
  /// The one policy for a late or missing answer (docs/hal.md, "Late or missing answers"): a
  /// device's last valid input is held, flagged InputStatus::kHeld and counted, for up to this
  /// many cycles in a row; the next missing one drops the device out of OP (SAFE-OP, latched)
  /// and is a safety fault (servo InputChecker reads the same value). 3 cycles = 3 ms at 1 kHz.
  int max_held_cycles = 5;
  int min_valid_cycles_for_op = 5;     // consecutive valid cycles in SAFE-OP before enabling
  /// The boards' own fault reaction (docs/can_protocol.md, "When the master goes silent"): a
  /// board in OPERATIONAL that gets no SYNC, or (outputs on) no set-point, for this long on its
  /// own timer sets 0 N·m, closes its valve, sends EMCY 0x8250 and leaves OPERATIONAL.
  double device_setpoint_timeout_s = 0.008;
  /// The master's heartbeat (node kMasterNodeId, NMT state operational), every this often on
  /// every bus; the boards consume it (CiA 301 heartbeat consumer, active after the first one):
  /// none for master_heartbeat_timeout_s in OPERATIONAL -> 0 N·m, EMCY 0x8130, PRE-OPERATIONAL.
  double master_heartbeat_period_s = 0.05;
  double master_heartbeat_timeout_s = 0.2;

  template <class A>
  void Serialize(A* a) {
    a->Visit(RetiredKey{"max_missed_cycles",
                        "timing.max_held_cycles (renamed: the one hold limit for late or missing "
                        "inputs, which the safety layer shares)",
                        "the old name"});
    a->Visit(Key("cycle_period_s", &cycle_period_s).Unit("s")
                 .Doc("the SYNC period (the servo file's loop.rate_hz replaces it)"));
    a->Visit(Key("state_timeout_s", &state_timeout_s).Unit("s")
                 .Doc("a requested state transition must finish within this"));
    a->Visit(Key("bringup_timeout_s", &bringup_timeout_s).Unit("s")
                 .Doc("all devices in the requested state within this"));
    a->Visit(Key("heartbeat_period_s", &heartbeat_period_s).Unit("s")
                 .Doc("the boards' producer heartbeat time"));
    a->Visit(Key("heartbeat_timeout_s", &heartbeat_timeout_s).Unit("s")
                 .Doc("no heartbeat for this long: the device is lost"));
    a->Visit(Key("max_held_cycles", &max_held_cycles).In(0, 1000)
                 .Doc("a late or missing input is held this many cycles in a row, then a fault"));
    a->Visit(Key("min_valid_cycles_for_op", &min_valid_cycles_for_op).In(1, 100000)
                 .Doc("consecutive valid cycles in SAFE-OP before enabling"));
    a->Visit(Key("device_setpoint_timeout_s", &device_setpoint_timeout_s).Unit("s")
                 .Doc("a board without SYNC or set-point this long stops on its own"));
  }
};

struct HalConfig {
  TimingConfig timing;
  double max_bus_load = 0.80;          // refuse a layout whose worst-case load exceeds this
  bool heartbeats_in_worst_case = true;  // count every heartbeat landing in the same cycle
  std::vector<BusConfig> buses;
  std::array<JointCalibration, kNumJoints> joints{};

  template <class A>
  void Serialize(A* a) {
    a->Visit("timing", &timing);
    a->Visit(Key("max_bus_load", &max_bus_load)
                 .Doc("refuse a layout whose worst-case load per cycle exceeds this (1 = 100 %)"));
    a->Visit(Key("heartbeats_in_worst_case", &heartbeats_in_worst_case)
                 .Doc("count every heartbeat landing in the same cycle"));
    a->Visit(Key("buses", &buses).Required().NonEmpty().Elements("buses")
                 .Doc("the CAN buses and their devices"));
    a->Visit(Key("joints", &joints).Required().Named(&JointName)
                 .Elements("joint name {lf,rf,lh,rh}_{haa,hfe,kfe}_joint")
                 .Doc("each joint's calibration (docs/hal.md, calibration)"));
  }
};

/// HyQ's default layout and calibration: the same numbers as config/hyq_hal.yaml (the tests check
/// that the two agree). Four FD buses at 1/5 Mbit/s, one per leg (nodes haa 1, hfe 2, kfe 3),
/// the IMU (node 16) on the lf bus.
HalConfig DefaultHalConfig();

/// Throws ConfigError when the configuration is unusable: no buses or more than kMaxBuses, more
/// than kMaxDevicesPerBus devices on a bus, a node id outside 1..127 or used twice on a bus, a
/// joint missing or configured twice, more than one IMU, a non-FD bus (the PDO layout needs FD),
/// a bad calibration (ValidateCalibration), bad timing, or a bus whose worst-case load exceeds
/// max_bus_load (CheckBusLoad).
void ValidateHalConfig(const HalConfig& config);

}  // namespace hyq::hal
