// libFuzzer target for the YAML configuration loaders (config/hal_config_loader.h,
// config/servo_config_loader.h): any text, as a HAL or a servo configuration, is accepted or
// refused with a ConfigError, never a crash, another exception, a hang or UB.
//
// The first byte picks the loader. The servo configuration's robot.hal is read from the project's
// config/ directory (HYQ_CONFIG_DIR), so a fuzzed path names at most a file there.
// Built with clang++ -fsanitize=fuzzer,address,undefined by tests/servo/CMakeLists.txt when
// clang++ is found; the ctest servo.fuzz_config_30s runs it for 30 s (label fuzz).
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "config/hal_config_loader.h"
#include "config/servo_config_loader.h"
#include "hal/config_error.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  if (text.find("/dev") != std::string::npos || text.find("/proc") != std::string::npos ||
      text.find("..") != std::string::npos)
    return 0;  // the fuzzer is not to read the machine's devices (the loaders refuse them anyway)
  try {
    if (data[0] % 2 == 0)
      (void)hyq::config::ParseHalConfig(text, "fuzz_hal.yaml");
    else
      (void)hyq::config::ParseServoConfig(text, "fuzz_servo.yaml", HYQ_CONFIG_DIR);
  } catch (const hyq::hal::ConfigError&) {
    // refused, naming the input: what must happen to bad input
  }
  return 0;
}
