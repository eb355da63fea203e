#include "config/servo_config_loader.h"

// GCC 12 warns falsely (-Wrestrict, bug 105329) on std::string operator+ chains at -O3; the
// messages here are built that way for readability.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wrestrict"
#endif

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <string>

#include "config/rate_bounds.h"
#include "config/yaml_archive.h"
#include "config/yaml_reader.h"
#include "hal/config_error.h"

namespace hyq::config {

using hal::ConfigError;

void ValidateServoConfig(const servo::ServoConfig& c) {
  auto fail = [&](const std::string& key, const std::string& expected, const std::string& found) {
    throw ConfigError(c.source + ": key '" + key + "': expected " + expected + ", found " + found);
  };
  if (c.commands.channel.rfind(c.telemetry.channel_prefix, 0) == 0)
    for (const char* suffix : {"JOINT_STATE", "JOINT_TORQUE", "BASE_STATE", "CONTACT", "TIMING",
                               "HEALTH", "EVENT"})
      if (c.commands.channel == c.telemetry.channel_prefix + suffix)
        fail("commands.channel", "a channel the telemetry does not publish on",
             "'" + c.commands.channel + "'");
  // the gains bounded at the loop rate, with the bounds of their keys
  if (const auto excess = detail::FindRateBoundExcess(c))
    fail(excess->key, excess->expected, excess->found);
  const bool pd = c.controller.kind == servo::ControllerKind::kPid
                      ? c.controller.pid.kp.maxCoeff() > 0.0
                  : c.controller.kind == servo::ControllerKind::kPdGravity
                      ? c.controller.pd_gravity.kp.maxCoeff() > 0.0
                      : (c.controller.feedback.kp_tau.maxCoeff() > 0.0 ||
                         c.controller.feedback.kp_acc.maxCoeff() > 0.0);
  if (!pd)
    fail("controller.gains", "a position gain > 0 for the chosen controller (" +
                                 std::string(servo::ToString(c.controller.kind)) + ")",
         "all position gains 0 (the robot would not hold a posture)");
  try {
    hal::ValidateHalConfig(c.hal);  // the bus load at this rate
  } catch (const ConfigError& e) {
    throw ConfigError(c.source + ": key 'loop.rate_hz' = " + detail::FormatNumber(c.rate_hz()) +
                      " Hz with " + c.hal_file + ": " + e.what());
  }
}

servo::ServoConfig ParseServoConfig(std::string_view yaml_text, std::string_view source_name,
                                    const std::filesystem::path& base_dir) {
  const detail::Reader r{std::string(source_name)};
  const YAML::Node root = detail::ParseYaml(r, std::string(yaml_text));
  servo::ServoConfig c;
  c.source = r.source();
  try {
    ReadYaml(r, root, base_dir, &c);
  } catch (const YAML::Exception& e) {
    throw ConfigError(r.source() + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  ValidateServoConfig(c);
  return c;
}

servo::ServoConfig LoadServoConfig(const std::filesystem::path& path) {
  return ParseServoConfig(detail::ReadTextFile(path, "the servo configuration"), path.string(),
                          path.parent_path());
}

}  // namespace hyq::config
