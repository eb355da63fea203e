// The one monotonic clock helper of the project (every layer above hal/ uses it).
#pragma once

#include <time.h>

#include <cstdint>

namespace hyq {

/// CLOCK_MONOTONIC in ns. Never allocates, never fails on Linux.
inline std::int64_t MonotonicNs() noexcept {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

/// The calling thread's CPU time in ns (CLOCK_THREAD_CPUTIME_ID).
inline std::int64_t ThreadCpuNs() noexcept {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

}  // namespace hyq
