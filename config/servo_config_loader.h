// YAML -> servo::ServoConfig, the daemon's configuration (config/hyq_servo.yaml is the default
// file and documents the format; docs/servo.md explains the settings).
#pragma once

#include <filesystem>
#include <string_view>

#include "servo/runtime/servo_config.h"

namespace hyq::config {

/// Reads and validates the daemon's configuration and the HAL configuration it names (paths are
/// relative to the file). Throws hal::ConfigError naming the file, the line, the key (a dotted
/// path), what was expected and what was found; unknown keys are errors.
servo::ServoConfig LoadServoConfig(const std::filesystem::path& path);

/// The same from text; relative paths resolve against `base_dir`.
servo::ServoConfig ParseServoConfig(std::string_view yaml_text, std::string_view source_name,
                                    const std::filesystem::path& base_dir);

/// The checks that involve more than one key (rates, gains against the period, the bus load at
/// the configured rate); ParseServoConfig calls it, the daemon calls it again after applying its
/// command-line overrides. Throws hal::ConfigError.
void ValidateServoConfig(const servo::ServoConfig& config);

}  // namespace hyq::config
