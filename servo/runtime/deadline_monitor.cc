#include "servo/runtime/deadline_monitor.h"

#include <algorithm>

namespace hyq::servo {

DeadlineMonitor::DeadlineMonitor(const DeadlineConfig& c, double period_s, bool enforce)
    : budget_ns_(static_cast<std::int64_t>(c.budget_fraction * period_s * 1e9)),
      limit_(static_cast<std::uint32_t>(c.max_consecutive_misses)),
      enforce_(enforce) {}

Fault DeadlineMonitor::Observe(std::int64_t used_ns, std::int64_t total_ns) noexcept {
  if (used_ns <= budget_ns_) {
    consecutive_ = 0;
    return {};
  }
  ++misses_;
  ++consecutive_;
  max_consecutive_ = std::max(max_consecutive_, consecutive_);
  if (!enforce_ || consecutive_ < limit_) return {};
  return MakeFault(EventReason::kDeadlineMiss, -1, -1,
                   "%u consecutive deadline misses (last %.1f us, budget %.1f us)", consecutive_,
                   1e-3 * static_cast<double>(total_ns), 1e-3 * static_cast<double>(budget_ns_));
}

}  // namespace hyq::servo
