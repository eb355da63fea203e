#include "qp/deadline.h"

#include <time.h>

#include <algorithm>

namespace hyq::qp {
namespace {

// qp/ depends on Eigen alone (docs/architecture.md), so it reads the two clocks itself instead
// of through hal/clock.h (MonotonicNs, ThreadCpuNs), which sits above it

std::int64_t WallNs() noexcept {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::int64_t ThreadCpuNs() noexcept {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return std::int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec;
}

}  // namespace

Deadline Deadline::In(std::chrono::nanoseconds budget, DeadlineClock clock) noexcept {
  Deadline d;
  d.clock_ = clock;
  d.wall_at_ns_ = WallNs() + budget.count();
  if (clock == DeadlineClock::kThreadCpu) d.cpu_at_ns_ = ThreadCpuNs() + budget.count();
  return d;
}

Deadline Deadline::At(std::chrono::steady_clock::time_point t) noexcept {
  Deadline d;
  d.wall_at_ns_ =
      std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
  return d;
}

std::chrono::nanoseconds Deadline::Remaining() const noexcept {
  const std::int64_t now = WallNs();
  std::int64_t left = wall_at_ns_ - now;
  if (left <= 0 && clock_ == DeadlineClock::kThreadCpu) {
    left = cpu_at_ns_ - ThreadCpuNs();
    if (left > 0) wall_at_ns_ = now + left;
  }
  return std::chrono::nanoseconds(std::max<std::int64_t>(left, 0));
}

bool Deadline::Passed() const noexcept { return Remaining().count() == 0; }

Deadline Deadline::Share(double share) const noexcept {
  const std::int64_t left = Remaining().count();
  const auto kept = static_cast<std::int64_t>((1.0 - std::clamp(share, 0.0, 1.0)) *
                                              static_cast<double>(left));
  Deadline d = *this;
  // the wall bound moves back by what is kept; so does the CPU deadline, which keeps at least
  // `kept` of CPU time too (Remaining() is at most the CPU time left)
  d.wall_at_ns_ = wall_at_ns_ - kept;
  if (clock_ == DeadlineClock::kThreadCpu) d.cpu_at_ns_ = cpu_at_ns_ - kept;
  return d;
}

}  // namespace hyq::qp
