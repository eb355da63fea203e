#include "servo/runtime/deadline_monitor.h"

#include <algorithm>
#include <utility>

namespace hyq::servo {

DeadlineMonitor::DeadlineMonitor(const DeadlineConfig& c, double period_s, bool enforce)
    : budget_ns_(static_cast<std::int64_t>(c.budget_fraction * period_s * 1e9)),
      limit_(static_cast<std::uint32_t>(c.max_consecutive_misses)),
      enforce_(enforce) {}

Fault DeadlineMonitor::Observe(std::int64_t used_ns, std::int64_t total_ns) noexcept {
  // the periods a stall took since the last cycle: misses in a row, before this one
  const std::uint32_t stalled = std::exchange(stalled_, 0);
  misses_ += stalled;
  consecutive_ += stalled;
  const bool miss = used_ns > budget_ns_;
  if (!miss && stalled == 0) {
    consecutive_ = 0;
    return {};
  }
  if (miss) {
    ++misses_;
    ++consecutive_;
  }
  max_consecutive_ = std::max(max_consecutive_, consecutive_);
  const std::uint32_t in_row = consecutive_;
  if (!miss) consecutive_ = 0;  // this cycle fits: the next run starts after it
  if (in_row < limit_ || !(enforce_ || stalled > 0)) return {};
  if (stalled > 0)
    return MakeFault(EventReason::kDeadlineMiss, -1, -1,
                     "%u consecutive deadline misses (%u periods lost to a stall, budget %.1f us)",
                     in_row, stalled, 1e-3 * static_cast<double>(budget_ns_));
  return MakeFault(EventReason::kDeadlineMiss, -1, -1,
                   "%u consecutive deadline misses (last %.1f us, budget %.1f us)", in_row,
                   1e-3 * static_cast<double>(total_ns), 1e-3 * static_cast<double>(budget_ns_));
}

}  // namespace hyq::servo
