#include "hal/process_image.h"

namespace hyq::hal {

const char* ToString(InputStatus s) noexcept {
  switch (s) {
    case InputStatus::kValid: return "valid";
    case InputStatus::kHeld: return "held";
    case InputStatus::kMissing: return "missing";
    case InputStatus::kDuplicate: return "duplicate";
    case InputStatus::kDeviceFault: return "device_fault";
    case InputStatus::kNotOperational: return "not_operational";
  }
  return "unknown";
}

}  // namespace hyq::hal
