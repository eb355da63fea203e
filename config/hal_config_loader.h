// YAML -> hal::HalConfig (house style §1: hal declares the struct, config/ fills it). The file
// format is documented by config/hyq_hal.yaml, the default file, and docs/hal.md.
#pragma once

#include <filesystem>
#include <string_view>

#include "hal/hal_config.h"

namespace hyq::config {

/// Reads and validates a HAL configuration (ValidateHalConfig, including the bus-load limit).
/// Throws hal::ConfigError naming the file, the line, the key (as a dotted path), what was
/// expected and what was found.
hal::HalConfig LoadHalConfig(const std::filesystem::path& path);

/// The same from text; `source_name` stands for the file name in messages.
hal::HalConfig ParseHalConfig(std::string_view yaml_text, std::string_view source_name);

}  // namespace hyq::config
