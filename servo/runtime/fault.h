// A fault found by one of the cycle's checks (inputs, estimate, controller output, deadline):
// what, where, and a short detail. Fixed size; formatting never allocates.
#pragma once

#include <array>
#include <cstdint>

#include "servo/common/servo_types.h"

namespace hyq::servo {

/// One problem found by a check: what, where, and a short human-readable detail.
struct Fault {
  EventReason reason = EventReason::kNone;
  std::int16_t joint = -1;
  std::int16_t bus = -1;
  bool imu = false;  // the IMU's input or device (joint −1)
  std::array<char, kEventDetailSize> detail{};
  explicit operator bool() const noexcept { return reason != EventReason::kNone; }
};

/// Formats a Fault's detail (printf-style, truncated to fit). Never allocates.
Fault MakeFault(EventReason reason, int joint, int bus, const char* fmt, ...) noexcept
    __attribute__((format(printf, 4, 5)));

}  // namespace hyq::servo
