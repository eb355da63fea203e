#include "hal/can_channel.h"

namespace hyq::hal {

const char* ToString(CanStatus s) noexcept {
  switch (s) {
    case CanStatus::kOk: return "ok";
    case CanStatus::kWouldBlock: return "would_block";
    case CanStatus::kBusOff: return "bus_off";
    case CanStatus::kBadFrame: return "bad_frame";
    case CanStatus::kIoError: return "io_error";
    case CanStatus::kClosed: return "closed";
  }
  return "unknown";
}

}  // namespace hyq::hal
