#include "config/hal_config_loader.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <initializer_list>
#include <limits>
#include <numbers>
#include <string>

#include "config/yaml_archive.h"
#include "config/yaml_reader.h"
#include "hal/config_error.h"

namespace hyq::config {
namespace {

using hal::ConfigError;
using detail::Describe;
using detail::Reader;

constexpr double kDeg = std::numbers::pi / 180.0;

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

}  // namespace

namespace detail {

void ReadJointCalibrations(const Reader& r, const YAML::Node& joints, const std::string& path,
                           std::array<hal::JointCalibration, hal::kNumJoints>* out) {
  if (!joints.IsMap()) r.Fail(joints, path, "a map", Describe(joints));
  for (const auto& kv : joints) {
    const std::string name = kv.first.as<std::string>();
    if (hal::JointIndex(name) < 0)
      r.Fail(kv.first, path + "." + name, "a joint name {lf,rf,lh,rh}_{haa,hfe,kfe}_joint",
             "'" + name + "'");
  }
  for (int j = 0; j < hal::kNumJoints; ++j) {
    const std::string name(hal::JointName(j));
    const YAML::Node n = joints[name];
    if (!n.IsDefined())
      r.Fail(joints, path + "." + name, "the calibration of every joint",
             "nothing (the key is missing)");
    (*out)[static_cast<std::size_t>(j)] = ReadJoint(r, n, path + "." + name);
  }
}

}  // namespace detail

hal::HalConfig ParseHalConfig(std::string_view yaml_text, std::string_view source_name) {
  const Reader r{std::string(source_name)};
  const YAML::Node root = detail::ParseYaml(r, std::string(yaml_text));
  hal::HalConfig c;
  try {
    ReadYaml(r, root, {}, &c);
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
