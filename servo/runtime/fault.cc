#include "servo/runtime/fault.h"

#include <cstdarg>
#include <cstdio>

namespace hyq::servo {

Fault MakeFault(EventReason reason, int joint, int bus, const char* fmt, ...) noexcept {
  Fault f;
  f.reason = reason;
  f.joint = static_cast<std::int16_t>(joint);
  f.bus = static_cast<std::int16_t>(bus);
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(f.detail.data(), f.detail.size(), fmt, args);
  va_end(args);
  return f;
}

}  // namespace hyq::servo
