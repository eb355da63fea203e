#include "config/config_reference.h"

#include "hal/hal_config.h"
#include "servo/runtime/servo_config.h"

namespace hyq::config {

namespace detail {

std::string MarkdownTable(const std::vector<KeyRow>& rows) {
  auto cell = [](const std::string& s) {
    std::string out;
    for (const char c : s) {
      if (c == '|') out += '\\';
      out += c;
    }
    return out;
  };
  std::string t = "| Key | Type and range | Default | Unit | Description |\n|---|---|---|---|---|\n";
  for (const KeyRow& r : rows)
    t += "| `" + r.key + "` | " + cell(r.type) + " | " + cell(r.default_value) + " | " + cell(r.unit) +
         " | " + cell(r.doc) + " |\n";
  return t;
}

}  // namespace detail

std::string ConfigReference() {
  return "### The servo file (`hyq-servod --config`, e.g. config/hyq_servo.yaml)\n\n"
         "Every section but `robot` is optional; dt is the loop period, 1 / `loop.rate_hz`.\n\n" +
         KeyTable<servo::ServoConfig>() +
         "\n### The HAL file (`robot.hal`, e.g. config/hyq_hal.yaml)\n\n"
         "`joints.<name>` is one map per joint; which sensor keys it has depends on its `actuator`.\n\n" + KeyTable(hal::DefaultHalConfig());
}

}  // namespace hyq::config
