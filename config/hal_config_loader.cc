#include "config/hal_config_loader.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <initializer_list>
#include <limits>
#include <numbers>
#include <string>

#include "config/yaml_reader.h"
#include "hal/config_error.h"

namespace hyq::config {
namespace {

using hal::ConfigError;
using detail::Describe;
using detail::Reader;

constexpr double kDeg = std::numbers::pi / 180.0;

hal::TimingConfig ReadTiming(const Reader& r, const YAML::Node& root) {
  hal::TimingConfig t;
  if (!root["timing"].IsDefined()) return t;
  const YAML::Node n = r.Map(root, "", "timing");
  if (n["max_missed_cycles"].IsDefined())
    r.Fail(n["max_missed_cycles"], "timing.max_missed_cycles",
           "timing.max_held_cycles (renamed: the one hold limit for late or missing inputs, "
           "which the safety layer shares)", "the old name");
  r.Keys(n, "timing", {"cycle_period_s", "state_timeout_s", "bringup_timeout_s",
                       "heartbeat_period_s", "heartbeat_timeout_s", "max_held_cycles",
                       "min_valid_cycles_for_op", "device_setpoint_timeout_s"});
  t.cycle_period_s = r.NumberOr(n, "timing", "cycle_period_s", t.cycle_period_s);
  t.state_timeout_s = r.NumberOr(n, "timing", "state_timeout_s", t.state_timeout_s);
  t.bringup_timeout_s = r.NumberOr(n, "timing", "bringup_timeout_s", t.bringup_timeout_s);
  t.heartbeat_period_s = r.NumberOr(n, "timing", "heartbeat_period_s", t.heartbeat_period_s);
  t.heartbeat_timeout_s = r.NumberOr(n, "timing", "heartbeat_timeout_s", t.heartbeat_timeout_s);
  t.device_setpoint_timeout_s =
      r.NumberOr(n, "timing", "device_setpoint_timeout_s", t.device_setpoint_timeout_s);
  if (n["max_held_cycles"].IsDefined())
    t.max_held_cycles = static_cast<int>(r.Integer(n, "timing", "max_held_cycles", 0, 1000));
  if (n["min_valid_cycles_for_op"].IsDefined())
    t.min_valid_cycles_for_op =
        static_cast<int>(r.Integer(n, "timing", "min_valid_cycles_for_op", 1, 100000));
  return t;
}

hal::BusConfig ReadBus(const Reader& r, const YAML::Node& n, const std::string& path) {
  if (!n.IsMap()) r.Fail(n, path, "a map describing a bus", Describe(n));
  r.Keys(n, path, {"name", "interface", "fd", "nominal_bitrate", "data_bitrate", "devices"});
  hal::BusConfig b;
  b.name = r.String(n, path, "name");
  b.interface = r.String(n, path, "interface");
  b.fd = r.Bool(n, path, "fd");
  b.nominal_bitrate =
      static_cast<std::uint32_t>(r.Integer(n, path, "nominal_bitrate", 10'000, 1'000'000));
  b.data_bitrate = b.nominal_bitrate;
  if (b.fd)
    b.data_bitrate =
        static_cast<std::uint32_t>(r.Integer(n, path, "data_bitrate", 10'000, 12'000'000));
  const YAML::Node devs = r.Child(n, path, "devices", "a list of devices");
  if (!devs.IsSequence() || devs.size() == 0)
    r.Fail(devs, path + ".devices", "a non-empty list of devices", Describe(devs));
  for (std::size_t i = 0; i < devs.size(); ++i) {
    const YAML::Node d = devs[i];
    const std::string dp = path + ".devices[" + std::to_string(i) + "]";
    if (!d.IsMap()) r.Fail(d, dp, "a map describing a device", Describe(d));
    r.Keys(d, dp, {"name", "kind", "node_id", "joint"});
    hal::DeviceConfig dc;
    dc.name = r.String(d, dp, "name");
    dc.kind = r.OneOf(d, dp, "kind", {"actuator", "imu"}) == "imu" ? hal::DeviceKind::kImu
                                                                   : hal::DeviceKind::kActuator;
    dc.node_id = static_cast<std::uint8_t>(r.Integer(d, dp, "node_id", 1, 127));
    if (dc.kind == hal::DeviceKind::kActuator) {
      const std::string joint = r.String(d, dp, "joint");
      dc.joint = hal::JointIndex(joint);
      if (dc.joint < 0)
        r.Fail(d["joint"], dp + ".joint", "a joint name {lf,rf,lh,rh}_{haa,hfe,kfe}_joint",
               "'" + joint + "'");
    } else if (d["joint"].IsDefined()) {
      r.Fail(d["joint"], dp + ".joint", "no joint for an IMU", Describe(d["joint"]));
    }
    b.devices.push_back(dc);
  }
  return b;
}

hal::JointCalibration ReadJoint(const Reader& r, const YAML::Node& n, const std::string& path) {
  if (!n.IsMap()) r.Fail(n, path, "a map describing the joint's calibration", Describe(n));
  hal::JointCalibration c;
  const std::string kind = r.OneOf(n, path, "actuator", {"rotary", "cylinder"});
  c.kind = kind == "rotary" ? hal::ActuatorKind::kRotary : hal::ActuatorKind::kCylinder;
  if (c.kind == hal::ActuatorKind::kRotary)
    r.Keys(n, path, {"actuator", "encoder", "torque_sensor", "range_deg", "torque_limit_Nm"});
  else
    r.Keys(n, path, {"actuator", "encoder", "load_cell", "cylinder", "range_deg", "torque_limit_Nm"});

  const YAML::Node enc = r.Map(n, path, "encoder");
  const std::string ep = path + ".encoder";
  r.Keys(enc, ep, {"counts_per_rev", "offset_counts", "direction"});
  c.encoder.counts_per_rev = r.Number(enc, ep, "counts_per_rev");
  if (!(c.encoder.counts_per_rev > 0.0))
    r.Fail(enc["counts_per_rev"], ep + ".counts_per_rev", "a number > 0",
           Describe(enc["counts_per_rev"]));
  c.encoder.offset_counts = static_cast<std::int32_t>(
      r.Integer(enc, ep, "offset_counts", std::numeric_limits<std::int32_t>::min(),
                std::numeric_limits<std::int32_t>::max()));
  c.encoder.direction = static_cast<int>(r.Integer(enc, ep, "direction", -1, 1));
  if (c.encoder.direction == 0) r.Fail(enc["direction"], ep + ".direction", "+1 or -1", "'0'");

  const char* sensor_key = c.kind == hal::ActuatorKind::kRotary ? "torque_sensor" : "load_cell";
  const char* gain_key =
      c.kind == hal::ActuatorKind::kRotary ? "gain_Nm_per_count" : "gain_N_per_count";
  const YAML::Node s = r.Map(n, path, sensor_key);
  const std::string sp = path + "." + sensor_key;
  r.Keys(s, sp, {gain_key, "offset_counts"});
  c.effort.gain = r.Number(s, sp, gain_key);
  if (c.effort.gain == 0.0) r.Fail(s[gain_key], sp + "." + gain_key, "a non-zero gain", "'0'");
  c.effort.offset_counts = static_cast<std::int32_t>(
      r.Integer(s, sp, "offset_counts", std::numeric_limits<std::int32_t>::min(),
                std::numeric_limits<std::int32_t>::max()));

  if (c.kind == hal::ActuatorKind::kCylinder) {
    const YAML::Node g = r.Map(n, path, "cylinder");
    const std::string gp = path + ".cylinder";
    r.Keys(g, gp, {"a_m", "b_m", "phi0_deg", "phi_per_q"});
    c.cylinder.a_m = r.Number(g, gp, "a_m");
    c.cylinder.b_m = r.Number(g, gp, "b_m");
    c.cylinder.phi0_rad = kDeg * r.Number(g, gp, "phi0_deg");
    c.cylinder.phi_per_q = static_cast<double>(r.Integer(g, gp, "phi_per_q", -1, 1));
    if (c.cylinder.phi_per_q == 0.0) r.Fail(g["phi_per_q"], gp + ".phi_per_q", "+1 or -1", "'0'");
  }

  const YAML::Node range = r.Child(n, path, "range_deg", "a list [min, max] in degrees");
  if (!range.IsSequence() || range.size() != 2)
    r.Fail(range, path + ".range_deg", "a list [min, max] in degrees", Describe(range));
  c.q_min_rad = kDeg * r.ToNumber(range[0], path + ".range_deg[0]");
  c.q_max_rad = kDeg * r.ToNumber(range[1], path + ".range_deg[1]");
  if (!(c.q_min_rad < c.q_max_rad))
    r.Fail(range, path + ".range_deg", "min < max", Describe(range[0]) + ", " + Describe(range[1]));
  c.torque_limit_Nm = r.Number(n, path, "torque_limit_Nm");
  return c;
}

hal::HalConfig Read(const Reader& r, const YAML::Node& root) {
  if (!root.IsMap()) r.Fail(root, "(top level)", "a map", Describe(root));
  r.Keys(root, "", {"timing", "max_bus_load", "heartbeats_in_worst_case", "buses", "joints"});
  hal::HalConfig c;
  c.timing = ReadTiming(r, root);
  c.max_bus_load = r.NumberOr(root, "", "max_bus_load", c.max_bus_load);
  if (root["heartbeats_in_worst_case"].IsDefined())
    c.heartbeats_in_worst_case = r.Bool(root, "", "heartbeats_in_worst_case");

  const YAML::Node buses = r.Child(root, "", "buses", "a list of buses");
  if (!buses.IsSequence() || buses.size() == 0)
    r.Fail(buses, "buses", "a non-empty list of buses", Describe(buses));
  for (std::size_t i = 0; i < buses.size(); ++i)
    c.buses.push_back(ReadBus(r, buses[i], "buses[" + std::to_string(i) + "]"));

  const YAML::Node joints = r.Map(root, "", "joints");
  for (const auto& kv : joints) {
    const std::string name = kv.first.as<std::string>();
    if (hal::JointIndex(name) < 0)
      r.Fail(kv.first, "joints." + name, "a joint name {lf,rf,lh,rh}_{haa,hfe,kfe}_joint",
             "'" + name + "'");
  }
  for (int j = 0; j < hal::kNumJoints; ++j) {
    const std::string name(hal::JointName(j));
    const YAML::Node n = joints[name];
    if (!n.IsDefined())
      r.Fail(joints, "joints." + name, "the calibration of every joint",
             "nothing (the key is missing)");
    c.joints[static_cast<std::size_t>(j)] = ReadJoint(r, n, "joints." + name);
  }
  return c;
}

}  // namespace

hal::HalConfig ParseHalConfig(std::string_view yaml_text, std::string_view source_name) {
  const Reader r{std::string(source_name)};
  const YAML::Node root = detail::ParseYaml(r, std::string(yaml_text));
  hal::HalConfig c;
  try {
    c = Read(r, root);
  } catch (const YAML::Exception& e) {
    throw ConfigError(r.source() + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  try {
    hal::ValidateHalConfig(c);
  } catch (const ConfigError& e) {
    throw ConfigError(r.source() + ": " + e.what());
  }
  return c;
}

hal::HalConfig LoadHalConfig(const std::filesystem::path& path) {
  return ParseHalConfig(detail::ReadTextFile(path, "the HAL configuration"), path.string());
}

}  // namespace hyq::config
