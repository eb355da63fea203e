#include "hal/hal_config.h"

#include <array>
#include <numbers>

#include "hal/bus_load.h"
#include "hal/config_error.h"
#include "hal/protocol.h"

namespace hyq::hal {
namespace {

constexpr std::array<std::string_view, kNumJoints> kJointNames = {
    "lf_haa_joint", "lf_hfe_joint", "lf_kfe_joint", "rf_haa_joint", "rf_hfe_joint", "rf_kfe_joint",
    "lh_haa_joint", "lh_hfe_joint", "lh_kfe_joint", "rh_haa_joint", "rh_hfe_joint", "rh_kfe_joint"};
constexpr std::array<std::string_view, kNumLegs> kLegs = {"lf", "rf", "lh", "rh"};

constexpr double Deg(double d) { return d * std::numbers::pi / 180.0; }

}  // namespace

std::string_view JointName(int joint) noexcept {
  return joint >= 0 && joint < kNumJoints ? kJointNames[static_cast<std::size_t>(joint)] : "";
}

int JointIndex(std::string_view name) noexcept {
  for (int i = 0; i < kNumJoints; ++i)
    if (kJointNames[static_cast<std::size_t>(i)] == name) return i;
  return -1;
}

std::vector<Choice<int>> JointChoices() {
  std::vector<Choice<int>> c;
  for (int i = 0; i < kNumJoints; ++i) c.push_back({kJointNames[static_cast<std::size_t>(i)].data(), i});
  return c;
}

HalConfig DefaultHalConfig() {
  HalConfig c;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    BusConfig bus;
    bus.name = std::string(kLegs[static_cast<std::size_t>(leg)]);
    bus.interface = "can" + std::to_string(leg);
    for (int k = 0; k < kJointsPerLeg; ++k) {
      static constexpr std::array<const char*, 3> kKinds = {"_haa", "_hfe", "_kfe"};
      DeviceConfig d;
      d.name = bus.name + kKinds[static_cast<std::size_t>(k)];
      d.kind = DeviceKind::kActuator;
      d.node_id = static_cast<std::uint8_t>(k + 1);
      d.joint = kJointsPerLeg * leg + k;
      bus.devices.push_back(d);
    }
    if (leg == 0) bus.devices.push_back({"imu", DeviceKind::kImu, 16, -1});
    c.buses.push_back(bus);
  }
  // Assumptions (see config/hyq_hal.yaml): 17-bit joint encoders, 24-bit load-cell ADC over
  // +-5 kN, 24-bit torque-sensor ADC over +-200 N·m, cylinder attachment points 50/300 mm (HFE)
  // and 40/290 mm (KFE) from the joint axis, the triangle's angle at 90 deg mid-range.
  for (int j = 0; j < kNumJoints; ++j) {
    const int leg = j / kJointsPerLeg, kind = j % kJointsPerLeg;
    const bool front = leg < 2, left = leg % 2 == 0;
    JointCalibration& jc = c.joints[static_cast<std::size_t>(j)];
    jc.encoder.counts_per_rev = 131072.0;
    jc.encoder.offset_counts = 20000 + 1500 * j;
    jc.encoder.direction = (kind == 0 && !left) ? -1 : 1;
    jc.torque_limit_Nm = 150.0;
    if (kind == 0) {
      jc.kind = ActuatorKind::kRotary;
      jc.effort = {200.0 / 8388607.0, -800};
      jc.q_min_rad = Deg(-70.0);
      jc.q_max_rad = Deg(25.0);
    } else {
      jc.kind = ActuatorKind::kCylinder;
      jc.effort = {5000.0 / 8388607.0, 1200};
      if (kind == 1) {
        jc.q_min_rad = front ? Deg(-50.0) : Deg(-70.0);
        jc.q_max_rad = front ? Deg(70.0) : Deg(50.0);
        jc.cylinder = {0.050, 0.300, front ? Deg(80.0) : Deg(100.0), 1.0};
      } else {
        jc.q_min_rad = front ? Deg(-140.0) : Deg(20.0);
        jc.q_max_rad = front ? Deg(-20.0) : Deg(140.0);
        jc.cylinder = {0.050, 0.290, Deg(190.0), front ? 1.0 : -1.0};
      }
    }
  }
  return c;
}

void ValidateHalConfig(const HalConfig& config) {
  const TimingConfig& t = config.timing;
  if (!(t.cycle_period_s > 0.0) || !(t.state_timeout_s > 0.0) || !(t.bringup_timeout_s > 0.0) ||
      !(t.heartbeat_period_s > 0.0) || !(t.heartbeat_timeout_s > t.heartbeat_period_s) ||
      t.max_held_cycles < 0 || t.min_valid_cycles_for_op < 1)
    throw ConfigError("HAL timing: expected all periods and timeouts > 0, heartbeat_timeout_s > "
                      "heartbeat_period_s, max_held_cycles >= 0, min_valid_cycles_for_op >= 1");
  if (!(t.master_heartbeat_period_s > 0.0) ||
      !(t.master_heartbeat_timeout_s > t.master_heartbeat_period_s))
    throw ConfigError("HAL timing: expected master_heartbeat_timeout_s > master_heartbeat_period_s "
                      "> 0, found " + std::to_string(t.master_heartbeat_timeout_s) + " and " +
                      std::to_string(t.master_heartbeat_period_s));
  if (!(config.max_bus_load > 0.0) || config.max_bus_load > 1.0)
    throw ConfigError("HAL max_bus_load: expected a fraction in (0, 1], found " +
                      std::to_string(config.max_bus_load));
  if (config.buses.empty() || config.buses.size() > static_cast<std::size_t>(kMaxBuses))
    throw ConfigError("HAL buses: expected 1.." + std::to_string(kMaxBuses) + " buses, found " +
                      std::to_string(config.buses.size()));
  std::array<int, kNumJoints> seen{};
  int imus = 0;
  for (std::size_t i = 0; i < config.buses.size(); ++i) {
    const BusConfig& b = config.buses[i];
    if (b.name.empty()) throw ConfigError("HAL buses[" + std::to_string(i) + "]: expected a name, found ''");
    for (std::size_t k = 0; k < i; ++k) {
      if (config.buses[k].name == b.name)
        throw ConfigError("HAL buses[" + std::to_string(i) + "]: expected a unique bus name, found '" +
                          b.name + "' a second time (buses[" + std::to_string(k) + "])");
      if (config.buses[k].interface == b.interface)
        throw ConfigError("bus '" + b.name + "': expected its own interface, found '" + b.interface +
                          "', the interface of bus '" + config.buses[k].name + "' too");
    }
  }
  for (const BusConfig& b : config.buses) {
    const std::string who = "bus '" + b.name + "': ";
    if (!b.fd)
      throw ConfigError(who + "the HyQ PDO layout (16-byte actuator TPDO) needs CAN FD; found a "
                        "classic bus");
    if (b.nominal_bitrate == 0 || b.data_bitrate < b.nominal_bitrate)
      throw ConfigError(who + "expected 0 < nominal_bitrate <= data_bitrate, found " +
                        std::to_string(b.nominal_bitrate) + " / " + std::to_string(b.data_bitrate));
    if (b.devices.size() > static_cast<std::size_t>(kMaxDevicesPerBus))
      throw ConfigError(who + "at most " + std::to_string(kMaxDevicesPerBus) +
                        " devices, found " + std::to_string(b.devices.size()));
    std::array<bool, kMaxNodeId + 1> used{};
    for (const DeviceConfig& d : b.devices) {
      if (d.node_id < kMinNodeId || d.node_id >= kMasterNodeId)
        throw ConfigError(who + "device '" + d.name + "': node_id must be 1..126 (127 is the "
                          "master's), found " + std::to_string(d.node_id));
      if (used[d.node_id])
        throw ConfigError(who + "node_id " + std::to_string(d.node_id) + " used twice (device '" +
                          d.name + "')");
      used[d.node_id] = true;
      if (d.kind == DeviceKind::kImu) {
        ++imus;
        continue;
      }
      if (d.joint < 0 || d.joint >= kNumJoints)
        throw ConfigError(who + "actuator '" + d.name + "' has no valid joint");
      ++seen[static_cast<std::size_t>(d.joint)];
    }
  }
  for (int j = 0; j < kNumJoints; ++j)
    if (seen[static_cast<std::size_t>(j)] != 1)
      throw ConfigError("HAL buses: joint " + std::string(JointName(j)) +
                        " must be driven by exactly one actuator, found " +
                        std::to_string(seen[static_cast<std::size_t>(j)]));
  if (imus != 1)  // the estimator needs the base's orientation and rate (servo/estimation)
    throw ConfigError("HAL buses: expected exactly one IMU (kind: imu; the state estimator needs "
                      "it), found " + std::to_string(imus));
  for (int j = 0; j < kNumJoints; ++j)
    ValidateCalibration(config.joints[static_cast<std::size_t>(j)], JointName(j));
  (void)CheckBusLoad(config);
}

}  // namespace hyq::hal
