#include "config/hal_config_loader.h"

#include <yaml-cpp/yaml.h>

#include <string>

#include "config/yaml_archive.h"
#include "config/yaml_reader.h"
#include "hal/config_error.h"

namespace hyq::config {

using hal::ConfigError;
using detail::Reader;

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
